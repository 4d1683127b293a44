/* Multiple scattering between microfacets by a random walk on the microsurface (Heitz, Hanika,
 * d'Eon & Dachsbacher 2016, "Multiple-scattering microfacet BSDFs with the Smith model"),
 * lane by lane: the kernels' counterpart of clbrdf/ref/heitz_ms.py, which states the walk.
 *
 * The microsurface is the Smith model's: heights uniform in [-1, 1] (C1(h) = (h + 1) / 2) and
 * the slopes of GGX or Beckmann (MF_DIST; alpha or alpha_x, alpha_y) of the model the walk
 * extends:
 *   microfacet (a conductor or any of its Fresnels, MODEL microfacet): the throughput is
 *       multiplied by ks F(wv.m) per channel at each hit;
 *   dielectric (MODEL dielectric, eta below relative to above): at each hit reflection with
 *       probability F (exact dielectric Fresnel of the side's relative index), refraction to
 *       the other side otherwise, weight 1 (energy); below the surface the microsurface is the
 *       mirror image (z and heights negated).
 * One event: the next height along the ray w from h0 (eqs 12-14): the ray leaves without a hit
 * with probability G1(w, h0) = C1(h0)^Lambda(w) (w up; 0 for w down, Lambda(-w) = -1 -
 * Lambda(w)), else it hits at C1^-1(C1(h0) / (1 - u)^(1 / Lambda)); at a hit a normal m of the
 * visible normals of wv = -w (GGX: spherical caps, valid for wv on either side of the horizon;
 * Beckmann: the model's sampler above it, ms_beckmann_below below it), and the reflection (or
 * refraction) of wv about m.
 * Random numbers: one Philox4x32-10 call per event, counter (walk, point, stream, event), so a
 * walk's numbers depend on nothing but its key (rng.h): u0 the height, u1 u2 the normal, u3 the
 * dielectric's branch; Beckmann's rejection below the horizon draws try j (>= 1) from counter
 * (walk, point, stream, event + j 2^20). A walk still on the surface after max_order hits is cut
 * (its weight is lost, and counted).
 */
#ifndef CLBRDF_HEITZ_MS_H
#define CLBRDF_HEITZ_MS_H

#if W == 1
#define MS_ANY(m) ((m) != 0)
#else
#define MS_ANY(m) any(m)
#endif

#define MS_ORDERS 3          /* the classes of order a walk is counted in: 1, 2, 3 and more */
#define MS_TRIES 64          /* rejection tries below the horizon: all fail with p < 0.66^64 */
#define MS_IS_beckmann 1

/* What a walk's random numbers are keyed by (the counter of Philox but the event's). */
typedef struct {
    uintN walk;
    uint point, stream, seed_lo, seed_hi;
} MsKey;

/* The four numbers of event `event` of walk k.walk: counter (walk, point, stream, event). */
FN rand4 ms_numbers(MsKey k, uintN event)
{
    uint4N c = {k.walk, (uintN)k.point, (uintN)k.stream, event};
    c = philox4x32_10(c, k.seed_lo, k.seed_hi);
    rand4 r = {bits_to_unit(c.c0), bits_to_unit(c.c1), bits_to_unit(c.c2), bits_to_unit(c.c3)};
    return r;
}

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

#if CAT(MS_IS_, MF_DIST)
/* Beckmann's visible normals of wv below the horizon (wv.z < 0, lanes `need`): in the stretched
 * frame, with wv at cot theta = -a < 0 in the x-z plane, the visible x-slopes have the density
 * (cot theta - x) P2(x) on x < cot theta, P2 the unit Gaussian exp(-x^2) / sqrt(pi) (Heitz &
 * d'Eon 2014 eq 3, valid for theta up to pi: clbrdf/ref/heitz_ms.py inverts its CDF); x = -a - t
 * with t of density t exp(-2 a t - t^2), by rejection: from t exp(-2 a t) (Gamma(2, 2a)),
 * accepted with exp(-t^2), where a > 1/sqrt(2), else from t exp(-t^2) (Rayleigh), accepted with
 * exp(-2 a t); each accepts at least 0.34 of its tries. No cancellation at any a. y = the
 * Gaussian slope of u2, as above the horizon. */
FN vec3 ms_beckmann_below(Microfacet m, vec3 wv, realN u2, MsKey k, uintN event, maskN need)
{
    vec3 ws = normalize3(v3(wv.x * m.ax, wv.y * m.ay, wv.z));
    realN rxy = fmax(sqrt(ws.x * ws.x + ws.y * ws.y), (realN)REAL_MIN);
    realN a = -ws.z / rxy;
    maskN gamma = a > (realN)0.70710678118654752;
    realN t = 0;
    maskN todo = need;
    for (uint j = 1; j <= MS_TRIES && MS_ANY(todo); ++j) {
        rand4 r = ms_numbers(k, event + (uintN)(j << 20));
        realN tg = -log(r.u0 * r.u1) / (2 * a), tr = sqrt(-log(r.u0));
        realN accept = sel(exp(-2 * a * tr), exp(-tg * tg), gamma);
        t = sel(t, sel(tr, tg, gamma), todo);
        todo = todo & !(r.u2 < accept);
    }
    realN x = -a - t, y = erfinv_r(fmax(2 * u2 - 1, -1 + REAL_EPS));
    realN cp = ws.x / rxy, sp = ws.y / rxy;
    return normalize3(slope_normal(m.ax * (cp * x - sp * y), m.ay * (sp * x + cp * y)));
}
#endif

/* The height step of event u0 for every lane still on the surface (eqs 12-14): the lanes
 * that leave (returned; s->w is the direction they leave along) or pass max_order hits (cut)
 * stop; the others (s->alive) move to the next hit's height and count it. */
ALWAYS_INLINE maskN ms_advance(Microfacet m, MsWalk *s, realN u0, uint max_order)
{
    maskN in = s->inside;
    vec3 wl = v3(s->w.x, s->w.y, sel(s->w.z, -s->w.z, in));   /* the side's own frame */
    realN hl = sel(s->h, -s->h, in);
    maskN leave;
    realN hn = ms_next_height(m, wl, hl, u0, &leave);
    leave = leave & s->alive;
    maskN over = s->alive & !leave & (s->order >= (realN)max_order);
    s->cut = s->cut | over;
    s->alive = s->alive & !leave & !over;
    s->h = sel(s->h, sel(hn, -hn, in), s->alive);
    s->order = s->order + sel((realN)0, (realN)1, s->alive);
    return leave;
}

/* The scattering at the hit of every lane s->alive (after ms_advance): a visible normal of the
 * reversed ray, then reflection (times F per channel) or, for the dielectric, reflection with
 * probability F and refraction otherwise. */
ALWAYS_INLINE void ms_scatter(const Params *p, Microfacet m, MsWalk *s, rand4 u, MsKey k,
                              uintN event)
{
    (void)p; (void)k; (void)event;
    maskN in = s->inside, hit = s->alive;
    vec3 wv = v3(-s->w.x, -s->w.y, sel(-s->w.z, s->w.z, in));  /* -w, the side's own frame */
    vec3 mm = normalize3(MF(sample_vndf)(m, wv, u.u1, u.u2));
#if CAT(MS_IS_, MF_DIST)
    maskN below = hit & (wv.z < 0);
    if (MS_ANY(below))
        mm = select3(mm, ms_beckmann_below(m, wv, u.u2, k, event, below), below);
#endif
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
}

/* One event (number `event`) of every lane still on the surface, from the numbers of key k.
 * Returns the lanes that left in it; lanes past max_order are cut. */
ALWAYS_INLINE maskN ms_step(const Params *p, Microfacet m, MsWalk *s, MsKey k, uintN event,
                            uint max_order)
{
    rand4 u = ms_numbers(k, event);
    maskN leave = ms_advance(m, s, u.u0, max_order);
    ms_scatter(p, m, s, u, k, event);
    return leave;
}

#if !CAT(MODEL, _TRANSMITS)
/* Next-event estimation toward wi (wi.z > 0, lam_i = Lambda(wi)) at the hit of every lane
 * s->alive, before it scatters (the paper's section 4.2; clbrdf.ref.heitz_ms.evaluate): the
 * throughput so far times F(v.m) p(v -> wi) G1(wi, h), v = -w the reversed ray, m the half
 * vector of v and wi, the phase function p = D(m) / (4 A(v)) (v.m > 0, m.z > 0; A(v) = v.z
 * (1 + Lambda(v)) the projected area, v on either side) and G1(wi, h) = C1(h)^Lambda(wi). */
FN spec ms_nee(const Params *p, Microfacet m, const MsWalk *s, vec3 wi, realN lam_i)
{
    vec3 v = scale3(s->w, (realN)-1);
    vec3 mh = normalize3(add3(v, wi));
    realN vm = dot3(v, mh);
    realN phase = MF(D)(m, mh) / (4 * v.z * (1 + ms_lambda(m, v)));
    realN g1 = pow(clamp((s->h + 1) / 2, (realN)0, (realN)1), lam_i);
    maskN ok = s->alive & (vm > 0) & (mh.z > 0);
    spec c;
    for (int ch = 0; ch < CHANNELS; ++ch)
        c.c[ch] = sel((realN)0, s->weight.c[ch] * mf_fresnel(p, vm, ch) * phase * g1, ok);
    return c;
}
#endif

#endif
