// Formula evaluation cost. Not a test (nothing is asserted): build and run with
//   cmake --build build --target formula_bench && build/tests/formula_bench
// Times are CPU time of this process, so other load on the machine inflates them less.
#include <algorithm>
#include <cstdio>
#include <ctime>
#include <random>
#include <string>
#include <vector>

#include "field/kernel.h"
#include "field/program.h"
#include "qjulia/field/formula.h"

namespace {

double cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

}  // namespace

int main() {
  using qjulia::Formula;
  using qjulia::Quat;
  const Quat constants[] = {Quat(0.1, 0.2, 0.3, 0.4), Quat(0.5, 0.1, 0, 0), Quat(-0.2, 0, 0.1, 0)};
  const int n = 10000000;
  std::printf("%-28s %4s %14s %14s\n", "formula", "ops", "ns/eval", "ns/orbit step");
  for (const char* text :
       {"h^2 + c", "p*h^2 + q", "(2*h^3+1)/(3*h^2)", "(h^4 - 1)/(4*h^3)*c + h"}) {
    const Formula f = Formula::compile(text, {"c", "p", "q"});
    // Independent evaluations (throughput), as when sampling many points.
    Quat h(0.3, -0.7, 0.4, 1.1), sum;
    double t0 = cpu_seconds();
    for (int k = 0; k < n; ++k) {
      h.w += 1e-9;
      sum = sum + f.eval(h, constants);
    }
    const double independent = (cpu_seconds() - t0) * 1e9 / n;
    // Dependent evaluations h <- f(h) (latency), as along one orbit.
    t0 = cpu_seconds();
    for (int k = 0; k < n / 20; ++k) {
      Quat g(0.3 + 1e-7 * k, -0.7, 0.4, 1.1);
      for (int s = 0; s < 20; ++s) g = f.eval(g, constants);
      sum = sum + g;
    }
    const double dependent = (cpu_seconds() - t0) * 1e9 / n;
    std::printf("%-28s %4zu %14.1f %14.1f   (checksum %g)\n", text, f.operation_count(),
                independent, dependent, sum.w);
  }
  // The Newton map written by hand with quaternion.h, the floor an interpreter can approach.
  Quat sum;
  const double t0 = cpu_seconds();
  for (int k = 0; k < n / 20; ++k) {
    Quat g(0.3 + 1e-7 * k, -0.7, 0.4, 1.1);
    for (int s = 0; s < 20; ++s) {
      const Quat g2 = sqr(g);
      g = (2.0 * (g2 * g) + Quat(1)) * inv(3.0 * g2);
    }
    sum = sum + g;
  }
  std::printf("%-28s %4s %14s %14.1f   (checksum %g)\n", "Newton by hand", "", "",
              (cpu_seconds() - t0) * 1e9 / n, sum.w);

  // The analytic functions on points spread over [-2, 2]^4 (a fixed point would flatter the
  // branches inside libm), independent evaluations; the loop over the points costs about 1 ns.
  std::vector<Quat> points(4096);
  std::mt19937 rng(15);
  std::uniform_real_distribution<double> uniform(-2, 2);
  for (Quat& q : points) q = Quat(uniform(rng), uniform(rng), uniform(rng), uniform(rng));
  const int m = 4000000;
  std::printf("\n%-28s %4s %14s\n", "function (points in [-2,2]^4)", "ops", "ns/eval");
  for (const char* text :
       {"h", "exp(h)", "log(h)", "sqrt(h)", "sin(h)", "cos(h)", "tan(h)", "sinh(h)", "cosh(h)",
        "tanh(h)", "h^1.5", "h^-0.5", "c*sin(h)", "exp(h)+c"}) {
    const Formula f = Formula::compile(text, {"c", "p", "q"});
    Quat acc;
    const double t1 = cpu_seconds();
    for (int k = 0; k < m; ++k) acc = acc + f.eval(points[k & 4095], constants);
    std::printf("%-28s %4zu %14.1f   (checksum %g)\n", text, f.operation_count(),
                (cpu_seconds() - t1) * 1e9 / m, acc.w);
  }

  // The same functions in the batched kernel's vector code (the current target), on the same
  // points: 4096 at a time, the time per point.
  std::printf("\n%-28s %14s   target %s\n", "function, batched", "ns/eval",
              qjulia::detail::kernel_target().c_str());
  using qjulia::detail::OpCode;
  const std::pair<const char*, OpCode> functions[] = {
      {"exp(h)", OpCode::kExp},   {"log(h)", OpCode::kLog},   {"sqrt(h)", OpCode::kSqrt},
      {"sin(h)", OpCode::kSin},   {"cos(h)", OpCode::kCos},   {"tan(h)", OpCode::kTan},
      {"sinh(h)", OpCode::kSinh}, {"cosh(h)", OpCode::kCosh}, {"tanh(h)", OpCode::kTanh},
      {"h^1.5", OpCode::kPowReal}};
  for (const auto& [name, code] : functions) {
    std::vector<double> runs;
    double check = 0;
    for (int r = 0; r < 5; ++r) {
      const double t1 = cpu_seconds();
      const int rounds = 200;
      for (int k = 0; k < rounds; ++k)
        check += qjulia::detail::kernel_analytic(code, points, 1.5)[k & 4095].w;
      runs.push_back((cpu_seconds() - t1) * 1e9 / (rounds * points.size()));
    }
    std::sort(runs.begin(), runs.end());
    std::printf("%-28s %14.1f   (checksum %g)\n", name, runs[2], check);
  }
  return 0;
}
