"""Tables: the one ``Table`` type (``table``), its axes (``axes``), how tables are computed
(``compute``: albedo tables; ``layouts``: the layouts renderers load), their files (``files``,
``cheader``), charts (``chart``), atomic outputs (``outputs``) and resumable runs
(``checkpoint``). Built on clbrdf.api.
"""
