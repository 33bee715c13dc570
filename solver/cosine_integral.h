// The exact integral of a unit SG against the clamped cosine,
//   C(lambda, c) = integral over the sphere of exp(lambda (w.mu - 1)) max(w.n, 0) dw,
// with c = mu.n. The paper replaces max(w.n, 0) by one SG (2.133, 1.170), which
// is off by -11 % at 45 degrees (method-notes.md); `sg` uses this instead.
#pragma once

namespace shadowsg {

struct CosineIntegral {
  double value = 0;
  double dlambda = 0;  // dC/dlambda
  double dc = 0;       // dC/dc
};

// Good to ~2e-7 of the lobe's power 2 pi (1 - e^{-2 lambda}) / lambda for
// lambda from 0.01 to 5000 (measured against a fine quadrature in cos(theta)
// split at the kinks; tests/sg_render_test.cc), and to ~6e-6 below 0.01.
CosineIntegral SgCosineIntegral(double lambda, double c);
// The same C without its derivatives, for a fifth of the time (they are
// central differences): renders and residuals need no more.
double SgCosineIntegralValue(double lambda, double c);

// C alone from a table the build computes (solver/cosine_table.h;
// bilinear in log lambda and c, to ~1e-3 of the lobe's power): for the many
// (lobe, surface) pairs of solver/caster_bounce.h, where the exact
// quadrature would cost seconds.
double SgCosineIntegralTabulated(double lambda, double c);

}  // namespace shadowsg
