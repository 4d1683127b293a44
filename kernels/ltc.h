/* Linearly transformed cosines (Heitz, Dupuy, Hill & Neubelt 2016, "Real-time polygonal-light
 * shading with linearly transformed cosines"): a distribution D over directions made from the
 * clamped cosine D_o(w) = max(w.z, 0) / pi by a 3x3 matrix M, w = M w_o / |M w_o| (eq. 1-2):
 *
 *     D(w) = D_o(M^-1 w / |M^-1 w|) |det M^-1| / |M^-1 w|^3          (eq. 3)
 *          = max(v.z, 0) |det M^-1| / (pi |v|^4),   v = M^-1 w
 *
 * and its integral over a polygon, the clamped cosine's integral over the polygon M^-1 P, in
 * closed form (eq. 11: Lambert's edge sum, after clipping to the horizon z = 0). Matrices are
 * row-major (m[3 r + c]: row r, column c). OpenCL C with lanes, and C99, C++ and CUDA through
 * clbrdf.h (docs/kernels.md); the float64 reference is clbrdf/ref/ltc.py.
 */
#ifndef CLBRDF_LTC_H
#define CLBRDF_LTC_H

typedef struct { realN m[9]; } mat3r;

FN vec3 mat3_apply(const mat3r *a, vec3 w)
{
    return v3(a->m[0] * w.x + a->m[1] * w.y + a->m[2] * w.z,
              a->m[3] * w.x + a->m[4] * w.y + a->m[5] * w.z,
              a->m[6] * w.x + a->m[7] * w.y + a->m[8] * w.z);
}

FN realN mat3_det(const mat3r *a)
{
    const realN *m = a->m;
    return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6])
         + m[2] * (m[3] * m[7] - m[4] * m[6]);
}

/* D(w) of the LTC whose inverse matrix is minv (eq. 3), in 1/sr; w need not be unit length
 * (D is homogeneous of degree -2 in w: a unit w is assumed). */
FN realN ltc_eval(const mat3r *minv, vec3 w)
{
    vec3 v = mat3_apply(minv, w);
    realN l2 = dot3(v, v);
    return fmax(v.z, (realN)0) * fabs(mat3_det(minv)) * INV_PI_R / (l2 * l2);
}

/* A direction distributed as D: the cosine sample of (u0, u1) through m, normalised. */
FN vec3 ltc_sample(const mat3r *m, realN u0, realN u1)
{
    return normalize3(mat3_apply(m, square_to_cosine_hemisphere(u0, u1)));
}

/* The integral over the great arc a -> b of Lambert's edge sum, (a x b).z / |a x b| times the
 * angle between a and b (eq. 11; a, b of any length): atan2 keeps short edges accurate, where
 * acos(a.b) loses half the digits. */
FN realN ltc_edge(vec3 a, vec3 b)
{
    vec3 c = v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
    realN s = sqrt(dot3(c, c)), t = atan2(s, dot3(a, b));
    return c.z * sel(t / s, (realN)1 / sqrt(dot3(a, a) * dot3(b, b)), s == (realN)0);
}

/* Where the segment a -> b crosses z = 0 (a.z and b.z of opposite signs). */
FN vec3 ltc_horizon_point(vec3 a, vec3 b)
{
    realN t = a.z / (a.z - b.z);
    return v3(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, (realN)0);
}

/* The azimuth of a point p on z = 0 seen from the origin, measured from the direction r (also
 * on z = 0): the edges that clipping adds along the horizon contribute differences of it. */
FN realN ltc_azimuth(vec3 r, vec3 p)
{
    return atan2(r.x * p.y - r.y * p.x, r.x * p.x + r.y * p.y);
}

/* (1 / 2 pi) times the edge sum of the polygon p[0..n-1] (planar, any winding, n >= 3) clipped
 * to z >= 0: the integral of the clamped cosine D_o over the polygon's solid angle, positive
 * where the vertices turn counter-clockwise about +z (as seen from above). Clipping
 * (Sutherland-Hodgman) keeps the part of each edge above the horizon and joins each exit point
 * to the next entry point along the horizon; those joins lie on one line of z = 0, the plane of
 * the polygon's intersection, so each contributes the difference of the azimuths of its ends:
 * the sum needs no branch per lane and no clipped vertex list. */
FN realN ltc_polygon_cosine(const vec3 *p, int n)
{
    /* the polygon's plane n . x = d meets z = 0 along a line whose nearest point lies along
     * (n.x d, n.y d): azimuths measured from there stay in (-pi/2, pi/2) on the line */
    vec3 e1 = sub3(p[1], p[0]), e2 = sub3(p[2], p[0]);
    vec3 nrm = v3(e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x);
    realN d = dot3(nrm, p[0]);
    vec3 r = v3(nrm.x * d, nrm.y * d, (realN)0);
    realN sum = 0;
    for (int i = 0; i < n; ++i) {
        vec3 a = p[i], b = p[i + 1 < n ? i + 1 : 0];
        maskN ina = a.z >= 0, inb = b.z >= 0;
        vec3 x = ltc_horizon_point(a, b);
        vec3 a2 = select3(x, a, ina), b2 = select3(x, b, inb);
        realN e = sel((realN)0, ltc_edge(a2, b2), ina | inb);
        /* an exit (a above, b below) starts a join at x: - azimuth; an entry ends one: + */
        realN phi = ltc_azimuth(r, x);
        e += sel((realN)0, -phi, ina & ~inb);
        e += sel((realN)0, phi, ~ina & inb);
        sum += e;
    }
    return sum * (realN)(0.5 * INV_PI_R);
}

/* The integral of D over the polygon p[0..n-1] (n <= 8; directions from the shading point, in
 * the LTC's frame): the cosine's integral over minv p (eq. 10). */
FN realN ltc_polygon(const mat3r *minv, const vec3 *p, int n)
{
    vec3 q[8];
    for (int i = 0; i < n && i < 8; ++i)
        q[i] = mat3_apply(minv, p[i]);
    return ltc_polygon_cosine(q, n < 8 ? n : 8);
}

#endif
