/* Host code (C99, C++, CUDA host): load the generated tables that gtr, sgd, exppow,
 * holzschuch_pacanowski and sgd_bagher read into one float array, in the order clbrdf_models.h
 * gives (CLBRDF_TABLE_NAMES, offsets TABLE_NAME). Include after clbrdf.h:
 *
 *     float *tables = clbrdf_tables_load("path/to/kernels/data");     NULL on failure (stderr says why)
 *     p.tables = tables;          C; on a GPU, copy it to the device and pass the device pointer
 *     ...
 *     free(tables);
 *
 * The files are NumPy .npy arrays (version 1 to 3 headers), 1-D little-endian float32: the data
 * the Python package hands its kernels, read as they are.
 */
#ifndef CLBRDF_TABLES_H
#define CLBRDF_TABLES_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Read DIR/NAME.npy (n float32 values) into out; 0 on success. */
static inline int clbrdf_npy_read(const char *dir, const char *name, float *out, long n)
{
    char path[4096];
    unsigned char head[10];
    snprintf(path, sizeof path, "%s/%s.npy", dir, name);
    FILE *f = fopen(path, "rb");
    if (!f) { fprintf(stderr, "clbrdf_tables_load: cannot open %s\n", path); return 1; }
    int ok = fread(head, 1, 10, f) == 10 && memcmp(head, "\x93NUMPY", 6) == 0;
    long hlen = 0;
    if (ok && head[6] == 1) {
        hlen = head[8] | (long)head[9] << 8;
    } else if (ok && (head[6] == 2 || head[6] == 3)) {
        unsigned char more[2];
        ok = fread(more, 1, 2, f) == 2;
        hlen = head[8] | (long)head[9] << 8 | (long)more[0] << 16 | (long)more[1] << 24;
    } else {
        ok = 0;
    }
    char *dict = ok ? (char *)malloc((size_t)hlen + 1) : NULL;
    if (dict) {
        ok = fread(dict, 1, (size_t)hlen, f) == (size_t)hlen;
        dict[ok ? hlen : 0] = 0;
        char shape[64];
        snprintf(shape, sizeof shape, "'shape': (%ld,)", n);
        ok = ok && strstr(dict, "'descr': '<f4'") && strstr(dict, "'fortran_order': False")
             && strstr(dict, shape);
        free(dict);
    }
    const unsigned one = 1;
    ok = ok && *(const unsigned char *)&one == 1                  /* a little-endian host */
         && fread(out, sizeof(float), (size_t)n, f) == (size_t)n;
    fclose(f);
    if (!ok) fprintf(stderr, "clbrdf_tables_load: %s is not a 1-D little-endian float32 array "
                     "of %ld values\n", path, n);
    return !ok;
}

/* All tables in one malloc'ed array of CLBRDF_TABLES_SIZE floats, or NULL. */
static inline float *clbrdf_tables_load(const char *dir)
{
    static const char *names[] = {CLBRDF_TABLE_NAMES};
    static const long offsets[] = {CLBRDF_TABLE_OFFSETS, CLBRDF_TABLES_SIZE};
    float *t = (float *)malloc(sizeof(float) * CLBRDF_TABLES_SIZE);
    if (!t) return NULL;
    for (size_t i = 0; i < sizeof names / sizeof names[0]; ++i)
        if (clbrdf_npy_read(dir, names[i], t + offsets[i], offsets[i + 1] - offsets[i])) {
            free(t);
            return NULL;
        }
    return t;
}

#endif
