#include "qjulia/field/classify.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "field/kernel.h"
#include "field/program.h"
#include "field/validated.h"
#include "qjulia/base/error.h"

namespace qjulia {
namespace {

constexpr int kMaxConstants = 16;
// F is clamped here so that a pole or an orbit stuck at infinity gives a finite value.
constexpr float kFieldLimit = 1e6f;

// a / (a + b) for a > 0, b >= 0, either possibly infinite: the fractional part of F.
double frac(double a, double b) {
  if (std::isinf(a)) return std::isinf(b) ? 0.5 : 1.0;
  if (std::isinf(b)) return 0.0;
  return a / (a + b);
}

float clamp_field(double f) {
  if (std::isnan(f)) return kFieldLimit;  // unreachable by construction; never output NaN
  return static_cast<float>(
      std::clamp(f, -static_cast<double>(kFieldLimit), static_cast<double>(kFieldLimit)));
}

}  // namespace

Classifier::Classifier(const Params& params) : params_(params) {
  formula_ = detail::validate_and_compile(params_);  // the names below, in the same order
  std::vector<std::string> names;
  for (const auto& [name, value] : params_.constants) {
    names.push_back(name);
    constants_.push_back(value);
  }
  if (params_.mode == Mode::kMandelbrot) {
    auto it = std::find(names.begin(), names.end(), "c");
    if (it == names.end()) {
      names.push_back("c");
      constants_.push_back(Quat{});
      it = names.end() - 1;
    }
    c_index_ = static_cast<int>(it - names.begin());
  }
  if (constants_.size() > kMaxConstants)
    throw InvalidInput("parameters: at most " + std::to_string(kMaxConstants) + " constants");
  slice_ = params_.slice.resolved();

  const Formula::Program& program = formula_.program();
  const int n_ops = static_cast<int>(program.ops.size());
  if (detail::kernel_target() != "scalar" && detail::kernel_supports(program.ops.data(), n_ops)) {
    auto k = std::make_shared<detail::KernelSetup>();
    k->ops = program.ops.data();
    k->op_count = n_ops;
    k->result = program.result;
    int top = program.result + 1;
    for (const detail::Op& op : program.ops) top = std::max({top, op.dst + 1, op.a + 1, op.b + 1});
    top = std::max(top, 1 + static_cast<int>(program.used_index.size()));
    k->registers = top;
    for (std::size_t u = 0; u < program.used_index.size(); ++u) {
      const int constant = program.used_index[u];
      k->init[1 + u] = constants_[constant];
      k->uniform[1 + u] = constant != c_index_;
      if (constant == c_index_) k->c_register = static_cast<int>(1 + u);
    }
    k->mandelbrot = c_index_ >= 0;
    k->start = params_.start;
    k->origin = slice_.origin;
    for (int a = 0; a < 3; ++a) k->dir[a] = slice_.directions[a];
    k->escape = params_.method == Method::kEscape;
    k->iterations = params_.iterations;
    k->r2 = params_.bailout * params_.bailout;
    k->log_r = std::log(params_.bailout);
    detail::prepare_kernel(*k);
    kernel_ = std::move(k);
  }
}

std::uint64_t Classifier::field(const double* x, const double* y, const double* z, std::size_t n,
                                float* out) const {
  return values(x, y, z, n, out, false);
}

std::uint64_t Classifier::root_field(const double* x, const double* y, const double* z,
                                     std::size_t n, float* out) const {
  return values(x, y, z, n, out, true);
}

std::uint64_t Classifier::values(const double* x, const double* y, const double* z, std::size_t n,
                                 float* out, bool root) const {
  if (kernel_) {
    // Straight into out, in blocks that bound the kernel's queue (about 80 bytes a point, kept
    // by each thread for its next call); the pipeline's batches are smaller than one.
    constexpr std::size_t kBlock = 16384;
    std::uint64_t steps = 0;
    for (std::size_t i = 0; i < n; i += kBlock)
      steps += detail::kernel_field(*kernel_, x + i, y + i, z + i, std::min(kBlock, n - i), out + i,
                                    root);
    return steps;
  }
  std::uint64_t steps = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Orbit o = orbit(x[i], y[i], z[i]);
    out[i] = root ? o.root : o.field;
    steps += o.exit_step >= 0 ? o.exit_step : params_.iterations;
  }
  return steps;
}

const detail::KernelSetup* Classifier::kernel() const { return kernel_.get(); }

std::string Classifier::evaluator() const { return kernel_ ? detail::kernel_target() : "scalar"; }

Quat Classifier::to_quaternion(double x, double y, double z) const {
  return slice_.origin + x * slice_.directions[0] + y * slice_.directions[1] +
         z * slice_.directions[2];
}

Orbit Classifier::orbit(double x, double y, double z) const {
  const Quat p = to_quaternion(x, y, z);
  // Julia mode evaluates with the constants as they are; Mandelbrot mode needs a copy with c
  // replaced by the sampled point.
  const Quat* consts = constants_.data();
  Quat local[kMaxConstants];
  Quat h = p;
  if (c_index_ >= 0) {
    std::copy(constants_.begin(), constants_.end(), local);
    local[c_index_] = p;
    consts = local;
    h = params_.start;
  }
  const int n_iter = params_.iterations;
  const double r2 = params_.bailout * params_.bailout;
  const double log_r = std::log(params_.bailout);
  Orbit out;
  if (params_.method == Method::kEscape) {
    // s_k = log(|h_k| / R); the orbit leaves at the first k with s_k > 0.
    double prev2 = norm2(h);
    double max2 = prev2;  // for the refinement value max_k s_k
    if (prev2 > r2) {
      const double s = 0.5 * std::log(prev2) - log_r;
      out.field = clamp_field(n_iter + frac(s, 1.0));
      out.root = clamp_field(s);
      out.exit_step = 0;
      out.last = h;
      return out;
    }
    for (int k = 1; k <= n_iter; ++k) {
      const Quat next = formula_.eval(h, consts);
      const double n2 = norm2(next);
      if (!std::isfinite(n2) || n2 > r2) {
        const double s = std::isfinite(n2) ? 0.5 * std::log(n2) - log_r
                                           : std::numeric_limits<double>::infinity();
        // s_(k-1) <= 0; -inf when h_(k-1) = 0 exactly, where F takes the step-0 form so that
        // it stays above N - k.
        const double s_prev = prev2 > 0 ? 0.5 * std::log(prev2) - log_r : -1.0;
        out.field = clamp_field((n_iter - k) + frac(s, -s_prev));
        out.root = clamp_field(s);
        out.exit_step = k;
        out.last = is_finite(next) ? next : h;
        return out;
      }
      h = next;
      prev2 = n2;
      max2 = std::max(max2, n2);
    }
    out.field = clamp_field(0.5 * std::log(prev2) - log_r);  // s_N <= 0
    out.root = clamp_field(0.5 * std::log(max2) - log_r);
    out.last = h;
    return out;
  }
  // Cut-off: t_k = log(|h_k - h_(k-1)| / R); converged at the first k with t_k < 0.
  double t_prev = std::numeric_limits<double>::infinity();
  double t_min = t_prev;  // for the refinement value -min_k t_k
  for (int k = 1; k <= n_iter; ++k) {
    const Quat next = formula_.eval(h, consts);
    const double d2 = norm2(next - h);
    if (!std::isfinite(d2)) {
      // A pole or an overflow: a large step, and the orbit stays at infinity, so it never
      // converges. The point is in the solid, well inside.
      out.field = -kFieldLimit;
      out.root = -kFieldLimit;
      out.last = is_finite(next) ? next : h;
      return out;
    }
    const double t = d2 > 0 ? 0.5 * std::log(d2) - log_r : -std::numeric_limits<double>::infinity();
    if (t < 0) {
      out.field =
          clamp_field(k == 1 ? (n_iter - 1) + frac(-t, 1.0) : (n_iter - k) + frac(-t, t_prev));
      out.root = clamp_field(-t);
      out.exit_step = k;
      out.last = next;
      return out;
    }
    t_prev = t;
    t_min = std::min(t_min, t);
    h = next;
  }
  out.field = clamp_field(-t_prev);  // -t_N <= 0
  out.root = clamp_field(-t_min);
  out.last = h;
  return out;
}

Solid::Solid(const Params& params) : classifier_(params) {
  min_ = params.bounds.min;
  max_ = params.bounds.max;
  for (ClipPlane c : params.mesh.clip) {
    const double n = std::sqrt(c.normal[0] * c.normal[0] + c.normal[1] * c.normal[1] +
                               c.normal[2] * c.normal[2]);
    for (double& v : c.normal) v /= n;
    c.d /= n;
    clip_.push_back(c);
  }
  voxel_ = grid_geometry(params).voxel;
}

Classifier Classifier::at_resolution(int resolution) const {
  Classifier c = *this;
  c.params_.resolution = resolution;
  return c;
}

Solid Solid::at_resolution(int resolution) const {
  Solid s = *this;
  s.classifier_ = classifier_.at_resolution(resolution);
  s.voxel_ = grid_geometry(s.classifier_.params()).voxel;
  return s;
}

namespace {

// The largest of three, the first of equals (as std::max({a, b, c})).
inline double first_max(double a, double b, double c) {
  double r = a;
  if (r < b) r = b;
  if (r < c) r = c;
  return r;
}

// The box's part of Solid::constraint(): how far (x, y, z) is outside [lo, hi].
inline double box_constraint(const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                             double x, double y, double z) {
  double c = -std::numeric_limits<double>::infinity();
  c = first_max(c, lo[0] - x, x - hi[0]);
  c = first_max(c, lo[1] - y, y - hi[1]);
  return first_max(c, lo[2] - z, z - hi[2]);
}

}  // namespace

double Solid::constraint(double x, double y, double z) const {
  double c = box_constraint(min_, max_, x, y, z);
  for (const ClipPlane& cp : clip_)
    c = std::max(c, cp.normal[0] * x + cp.normal[1] * y + cp.normal[2] * z - cp.d);
  return c;
}

double Solid::constraint_crossing(const std::array<double, 3>& in,
                                  const std::array<double, 3>& out) const {
  double s = 1.0;
  // Each wall and plane is a linear function of the position; the first one to turn positive.
  auto piece = [&](double at_in, double at_out) {
    if (at_out > 0 && at_in <= 0) s = std::min(s, -at_in / (at_out - at_in));
  };
  for (int a = 0; a < 3; ++a) {
    piece(min_[a] - in[a], min_[a] - out[a]);
    piece(in[a] - max_[a], out[a] - max_[a]);
  }
  for (const ClipPlane& c : clip_) {
    const double li = c.normal[0] * in[0] + c.normal[1] * in[1] + c.normal[2] * in[2] - c.d;
    const double lo = c.normal[0] * out[0] + c.normal[1] * out[1] + c.normal[2] * out[2] - c.d;
    piece(li, lo);
  }
  return s;
}

std::optional<float> Solid::excluded_field(double x, double y, double z) const {
  const double c = constraint(x, y, z) / voxel_;
  if (c > 0) return static_cast<float>(std::max(c, 1e-6));
  return std::nullopt;
}

std::uint64_t Solid::field(const double* x, const double* y, const double* z, std::size_t n,
                           float* out) const {
  return values(x, y, z, n, out, false);
}

std::uint64_t Solid::root_field(const double* x, const double* y, const double* z, std::size_t n,
                                float* out) const {
  return values(x, y, z, n, out, true);
}

std::uint64_t Solid::values(const double* x, const double* y, const double* z, std::size_t n,
                            float* out, bool root) const {
  if (!has_clip()) {
    // Points of the grid are inside the box: only callers with points outside need the
    // constraint, and they are the refinement, which asks point by point near the walls.
    thread_local std::vector<double> c;
    c.resize(n);
    // (Without a branch or a short circuit: the loop runs in vectors.)
    unsigned all_in_box = 1;
    for (std::size_t i = 0; i < n; ++i) {
      c[i] = box_constraint(min_, max_, x[i], y[i], z[i]);
      all_in_box &= c[i] <= 0;
    }
    if (all_in_box) {
      const std::uint64_t steps =
          root ? classifier_.root_field(x, y, z, n, out) : classifier_.field(x, y, z, n, out);
      for (std::size_t i = 0; i < n; ++i)
        out[i] = std::max(out[i], static_cast<float>(c[i] / voxel_));
      return steps;
    }
  }
  // Evaluate the points the constraints keep, then combine.
  std::vector<double> cx, cy, cz;
  std::vector<std::size_t> where;
  std::vector<double> c(n);
  for (std::size_t i = 0; i < n; ++i) {
    c[i] = constraint(x[i], y[i], z[i]) / voxel_;
    if (c[i] > 0) {
      out[i] = static_cast<float>(std::max(c[i], 1e-6));
    } else {
      where.push_back(i);
      cx.push_back(x[i]);
      cy.push_back(y[i]);
      cz.push_back(z[i]);
    }
  }
  std::vector<float> f(where.size());
  const std::uint64_t steps =
      classifier_.field(cx.data(), cy.data(), cz.data(), where.size(), f.data());
  for (std::size_t j = 0; j < where.size(); ++j)
    out[where[j]] = std::max(f[j], static_cast<float>(c[where[j]]));
  return steps;
}

float Solid::field(double x, double y, double z) const {
  const double c = constraint(x, y, z) / voxel_;
  if (c > 0) return static_cast<float>(std::max(c, 1e-6));
  return std::max(classifier_.field(x, y, z), static_cast<float>(c));
}

}  // namespace qjulia
