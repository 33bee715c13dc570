// The table behind SgCosineIntegralTabulated (solver/cosine_integral.h):
// C lambda / (2 pi (1 - e^{-2 lambda})), C over the lobe's power, which is
// bounded and smooth in both arguments, at 64 sharpness values spaced evenly
// in log lambda and 129 cosines spaced evenly in [-1, 1].
//
// The build computes it once (solver/cosine_table_gen.cc writes
// cosine_table.inc) from the same quadrature as SgCosineIntegral: filled at
// run time, the rows a solve touches cost it 50-55 ms on one core, most of
// it while the other threads waited (fast, synth_env and the interior).
#pragma once

namespace shadowsg {

constexpr int kCosineTableLambdas = 64, kCosineTableCosines = 129;
constexpr double kCosineTableLogMin = -4.6, kCosineTableLogMax = 9.3;  // lambda 0.01 .. 1.1e4

// Entry (l, k) from the quadrature: what the table holds, before rounding to float.
double SgCosineTableEntry(int l, int k);

// Row l of the built table (kCosineTableCosines floats).
const float* SgCosineTableRow(int l);

}  // namespace shadowsg
