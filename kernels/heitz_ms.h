/* Multiple scattering between microfacets by a random walk on the microsurface (Heitz, Hanika,
 * d'Eon & Dachsbacher 2016, "Multiple-scattering microfacet BSDFs with the Smith model"),
 * lane by lane: the kernels' counterpart of clbrdf/ref/heitz_ms.py, which states the walk.
 *
 * The microsurface is the Smith model's: heights uniform in [-1, 1] (C1(h) = (h + 1) / 2) and
 * the slopes of GGX (MF_DIST ggx; alpha or alpha_x, alpha_y) of the model the walk extends:
 *   microfacet (a conductor or any of its Fresnels, MODEL microfacet): the throughput is
 *       multiplied by ks F(wv.m) per channel at each hit;
 *   dielectric (MODEL dielectric, eta below relative to above): at each hit reflection with
 *       probability F (exact dielectric Fresnel of the side's relative index), refraction to
 *       the other side otherwise, weight 1 (energy); below the surface the microsurface is the
 *       mirror image (z and heights negated).
 * One event: the next height along the ray w from h0 (eqs 12-14): the ray leaves without a hit
 * with probability G1(w, h0) = C1(h0)^Lambda(w) (w up; 0 for w down, Lambda(-w) = -1 -
 * Lambda(w)), else it hits at C1^-1(C1(h0) / (1 - u)^(1 / Lambda)); at a hit a normal m of the
 * visible normals of wv = -w (spherical caps, valid for wv on either side of the horizon), and
 * the reflection (or refraction) of wv about m.
 * Random numbers: one Philox4x32-10 call per event, counter (walk, point, stream, event), so a
 * walk's numbers depend on nothing but its key (rng.h): u0 the height, u1 u2 the normal, u3 the
 * dielectric's branch. A walk still on the surface after max_order hits is cut (its weight is
 * lost, and counted).
 */
#ifndef CLBRDF_HEITZ_MS_H
#define CLBRDF_HEITZ_MS_H

#if W == 1
#define MS_ANY(m) ((m) != 0)
#else
#define MS_ANY(m) any(m)
#endif

#define MS_ORDERS 3          /* the classes of order a walk is counted in: 1, 2, 3 and more */

typedef struct {
    vec3 w;                  /* the ray's direction, fixed frame */
    realN h;                 /* its height, fixed frame */
    spec weight;
    realN order;             /* hits so far */
    maskN alive, cut, inside;
} MsWalk;

FN Microfacet ms_distribution(const Params *p)
{
#if CAT(MODEL, _TRANSMITS)
    return di_distribution(p);
#else
    return mf_distribution(p);
#endif
}

/* Smith Lambda for either sign of w.z: Lambda(-w) = -1 - Lambda(w). */
FN realN ms_lambda(Microfacet m, vec3 w)
{
    realN l = MF(Lambda)(m, w);
    return sel(l, -1 - l, w.z < 0);
}

/* The height of the next hit along w from h0, and where the ray leaves instead (eqs 12-14). */
FN realN ms_next_height(Microfacet m, vec3 w, realN h0, realN u, maskN *leave)
{
    realN c0 = clamp((h0 + 1) / 2, (realN)0, (realN)1);
    realN lam = ms_lambda(m, w);
    realN g1 = sel((realN)0, pow(c0, lam), w.z >= 0);
    *leave = (w.z >= 0) & (u > 1 - g1);
    realN c = c0 / pow(1 - u, 1 / lam);
    return 2 * clamp(c, (realN)0, (realN)1) - 1;
}

/* A walk toward the surface along -wo, from just beyond the microsurface on wo's side (below
 * it where wo.z < 0: the dielectric seen from inside). */
FN MsWalk ms_start(vec3 wo)
{
    MsWalk s;
    s.w = scale3(wo, (realN)-1);
    s.inside = wo.z < 0;
    s.h = sel((realN)(1 + 1e-4), (realN)(-1 - 1e-4), s.inside);
    s.weight = spec_splat((realN)1);
    s.order = (realN)0;
    s.alive = TO_MASK((uintN)1 == (uintN)1);
    s.cut = TO_MASK((uintN)1 == (uintN)0);
    return s;
}

/* One event of every lane still on the surface, from the numbers u. Returns the lanes that
 * left in it (their s->w is the direction they leave along); lanes past max_order are cut. */
ALWAYS_INLINE maskN ms_step(const Params *p, Microfacet m, MsWalk *s, rand4 u, uint max_order)
{
    (void)p;
    maskN in = s->inside;
    vec3 wl = v3(s->w.x, s->w.y, sel(s->w.z, -s->w.z, in));   /* the side's own frame */
    realN hl = sel(s->h, -s->h, in);
    maskN leave;
    realN hn = ms_next_height(m, wl, hl, u.u0, &leave);
    leave = leave & s->alive;
    maskN over = s->alive & !leave & (s->order >= (realN)max_order);
    s->cut = s->cut | over;
    s->alive = s->alive & !leave & !over;
    maskN hit = s->alive;
    s->h = sel(s->h, sel(hn, -hn, in), hit);
    s->order = s->order + sel((realN)0, (realN)1, hit);
    vec3 wv = scale3(wl, (realN)-1);
    vec3 mm = normalize3(MF(sample_vndf)(m, wv, u.u1, u.u2));
    realN c = dot3(wv, mm);
    vec3 r = sub3(scale3(mm, 2 * c), wv);
#if CAT(MODEL, _TRANSMITS)
    realN e = sel(p->eta, 1 / p->eta, in);
    realN F = fresnel_dielectric(e, c);
    maskN refl = u.u3 < F;
    realN ct = -safe_sqrt(1 - (1 - c) * (1 + c) / (e * e));
    vec3 t = normalize3(sub3(scale3(mm, c / e + ct), scale3(wv, 1 / e)));
    vec3 nw = select3(t, r, refl);
    s->inside = sel(in, sel(!in, in, refl), hit);
#else
    vec3 nw = r;
    for (int ch = 0; ch < CHANNELS; ++ch)
        s->weight.c[ch] = sel(s->weight.c[ch], s->weight.c[ch] * mf_fresnel(p, c, ch), hit);
#endif
    nw.z = sel(nw.z, -nw.z, in);                                 /* back to the fixed frame */
    s->w = select3(s->w, nw, hit);
    return leave;
}

#endif
