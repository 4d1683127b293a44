"""Studies built on tables and the API: the property battery (``check``), energy-conservation
sweeps (``sweep``, ``sweepjob``, ``cluster``, ``report``), the accuracy and stability maps
(``accuracy``, ``stability``), the least model a job needs (``ladder``), the white furnace of a
layout (``furnace``) and the C API cross-checks (``capi``).
"""
