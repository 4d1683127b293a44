/* Fresnel reflectance as a function of c = cos(theta_d) = wi . h (MODELS.md section 1). */
#ifndef CLBRDF_FRESNEL_H
#define CLBRDF_FRESNEL_H

/* Schlick 1994 eq 11: F0 + (1 - F0)(1 - c)^5. */
inline realN fresnel_schlick(realN f0, realN c)
{
    realN m = clamp(1 - c, (realN)0, (realN)1), m2 = m * m;
    return f0 + (1 - f0) * (m2 * m2 * m);
}

/* Exact unpolarised dielectric (Cook & Torrance 1982, eq 8 of their appendix), relative index
 * eta of the inside to the outside; total internal reflection (g^2 < 0) gives 1. */
inline realN fresnel_dielectric(realN eta, realN c)
{
    realN g2 = eta * eta + c * c - 1;
    realN g = safe_sqrt(g2);
    realN a = (g - c) / (g + c);
    realN b = (c * (g + c) - 1) / (c * (g - c) + 1);
    return sel((realN)0.5 * a * a * (1 + b * b), (realN)1, g2 < 0);
}

/* Unpolarised conductor with complex index eta + i k (Born & Wolf; real arithmetic form):
 * Rs = (a2+b2 - 2a c + c^2)/(a2+b2 + 2a c + c^2), Rp = Rs (..)/(..), F = (Rs + Rp)/2. */
inline realN fresnel_conductor(realN eta, realN k, realN c)
{
    realN c2 = c * c, s2 = 1 - c2, s4 = s2 * s2;
    realN t1 = eta * eta - k * k - s2;
    realN a2pb2 = sqrt(t1 * t1 + 4 * k * k * eta * eta);
    realN a = safe_sqrt((realN)0.5 * (a2pb2 + t1));
    realN term1 = a2pb2 + c2, term2 = 2 * a * c;
    realN rs = (term1 - term2) / (term1 + term2);
    realN term3 = a2pb2 * c2 + s4, term4 = term2 * s2;
    realN rp = rs * (term3 - term4) / (term3 + term4);
    return (realN)0.5 * (rp + rs);
}

#endif
