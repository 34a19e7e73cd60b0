#include "hdr/response.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

#include "core/color.h"
#include "core/error.h"
#include "core/json_node.h"
#include "core/json_settings.h"

namespace mr {

namespace {

// Debevec's hat: zero at both ends of the code range, largest in the middle.
double Hat(int level, int levels) { return std::min(level, levels - 1 - level); }

int Level(double z, int levels) { return std::clamp(static_cast<int>(std::lround(z * (levels - 1))), 0, levels - 1); }

void CheckBracket(const std::vector<Exposure>& bracket) {
  if (bracket.size() < 2) ThrowError("a response needs at least two exposures, got {}", bracket.size());
  const Image& first = bracket[0].codes;
  for (const Exposure& e : bracket) {
    if (e.codes.width() != first.width() || e.codes.height() != first.height() ||
        e.codes.channels() != first.channels())
      ThrowError("{}: {}x{}x{} while {} is {}x{}x{}", e.name, e.codes.width(), e.codes.height(), e.codes.channels(),
                 bracket[0].name, first.width(), first.height(), first.channels());
    if (!(e.time_s > 0) || !std::isfinite(e.time_s))
      ThrowError("{}: exposure time {} is not positive", e.name, e.time_s);
  }
  const auto [lo, hi] = std::minmax_element(bracket.begin(), bracket.end(),
                                            [](const Exposure& a, const Exposure& b) { return a.time_s < b.time_s; });
  if (hi->time_s <= lo->time_s * (1 + 1e-9))
    ThrowError("all {} exposures have the same time ({} s): a response needs different exposures", bracket.size(),
               lo->time_s);
}

// Pixels whose codes are valid in every exposure, on a grid of about
// `target` candidates.
std::vector<int64_t> CandidatePixels(const std::vector<Exposure>& bracket, int64_t target) {
  const Image& img = bracket[0].codes;
  const int64_t n = img.pixel_count();
  const int stride =
      std::max<int>(1, static_cast<int>(std::sqrt(static_cast<double>(n) / std::max<int64_t>(target, 1))));
  std::vector<int64_t> out;
  for (int y = 1; y + 1 < img.height(); y += stride)
    for (int x = 1; x + 1 < img.width(); x += stride) {
      const int64_t p = static_cast<int64_t>(y) * img.width() + x;
      bool ok = true;
      for (const Exposure& e : bracket) ok = ok && e.Valid(p);
      if (ok) out.push_back(p);
    }
  return out;
}

double GrayCode(const Image& img, int64_t p) {
  const int c = img.channels();
  double s = 0;
  for (int k = 0; k < c; ++k) s += img.values()[static_cast<size_t>(p * c + k)];
  return s / c;
}

// Debevec's advice: pixels spread over the code range, from smooth regions
// (where small misalignment and blur change nothing).  Binned by the middle
// exposure's code; in each bin the smoothest first.
std::vector<int64_t> ChooseDebevecSamples(const std::vector<Exposure>& bracket, int samples) {
  const std::vector<int64_t> cand = CandidatePixels(bracket, 40000);
  const Image& mid = bracket[bracket.size() / 2].codes;
  const int w = mid.width();
  constexpr int kBins = 32;
  std::vector<std::vector<std::pair<double, int64_t>>> bins(kBins);
  for (int64_t p : cand) {
    double grad = 0;
    for (const Exposure& e : bracket) {
      const double c = GrayCode(e.codes, p);
      grad += std::abs(GrayCode(e.codes, p + 1) - c) + std::abs(GrayCode(e.codes, p + w) - c) +
              std::abs(GrayCode(e.codes, p - 1) - c) + std::abs(GrayCode(e.codes, p - w) - c);
    }
    const int b = std::clamp(static_cast<int>(GrayCode(mid, p) * kBins), 0, kBins - 1);
    bins[b].push_back({grad, p});
  }
  std::vector<int64_t> out;
  const int per_bin = std::max(1, samples / kBins);
  for (auto& b : bins) {
    std::sort(b.begin(), b.end());
    for (int i = 0; i < per_bin && i < static_cast<int>(b.size()); ++i) out.push_back(b[static_cast<size_t>(i)].second);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Keeps g increasing (a response cannot fold back); returns entries changed.
int MakeIncreasing(std::vector<double>* g) {
  int fixes = 0;
  for (size_t k = 1; k < g->size(); ++k)
    if (!((*g)[k] > (*g)[k - 1])) {
      (*g)[k] = (*g)[k - 1] + 1e-6;
      ++fixes;
    }
  return fixes;
}

std::vector<double> SolveDebevec(const std::vector<Exposure>& bracket, const std::vector<int64_t>& pix, int c,
                                 const ResponseOptions& o, double* rms_log) {
  const int L = o.levels;
  const int n = static_cast<int>(pix.size());
  const int unknowns = L + n;
  std::vector<Eigen::Triplet<double>> trip;
  std::vector<double> rhs, data_weight;
  int row = 0;
  for (int i = 0; i < n; ++i)
    for (const Exposure& e : bracket) {
      const double z = e.codes.values()[static_cast<size_t>(pix[static_cast<size_t>(i)] * e.codes.channels() + c)];
      const int k = Level(z, L);
      const double wgt = Hat(k, L);
      if (wgt <= 0) continue;
      trip.emplace_back(row, k, wgt);
      trip.emplace_back(row, L + i, -wgt);
      rhs.push_back(wgt * std::log(e.time_s));
      data_weight.push_back(wgt);
      ++row;
    }
  const int data_rows = row;
  trip.emplace_back(row, L / 2, 1.0);  // g(middle) = 0 fixes the scale
  rhs.push_back(0);
  ++row;
  for (int k = 1; k + 1 < L; ++k) {
    const double s = o.smoothness * Hat(k, L);
    trip.emplace_back(row, k - 1, s);
    trip.emplace_back(row, k, -2 * s);
    trip.emplace_back(row, k + 1, s);
    rhs.push_back(0);
    ++row;
  }
  Eigen::SparseMatrix<double> A(row, unknowns);
  A.setFromTriplets(trip.begin(), trip.end());
  const Eigen::Map<const Eigen::VectorXd> b(rhs.data(), row);
  Eigen::SparseMatrix<double> AtA = A.transpose() * A;
  for (int k = 0; k < unknowns; ++k) AtA.coeffRef(k, k) += 1e-10;  // pixels seen only at the ends
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(AtA);
  if (solver.info() != Eigen::Success) ThrowError("the response's least-squares system could not be factored");
  const Eigen::VectorXd x = solver.solve(A.transpose() * b);
  const Eigen::VectorXd r = (A * x - b).head(data_rows);
  // RMS in ln X: the rows are weighted by w, so divide it out again.
  double ss = 0, ws = 0;
  for (int i = 0; i < data_rows; ++i) {
    ss += r[i] * r[i];
    ws += data_weight[static_cast<size_t>(i)] * data_weight[static_cast<size_t>(i)];
  }
  *rms_log = ws > 0 ? std::sqrt(ss / ws) : 0;
  return std::vector<double>(x.data(), x.data() + L);
}

// Robertson, Borman & Stevenson: alternate the irradiances given the
// response and the response (the mean exposure per code) given them.
std::vector<double> SolveRobertson(const std::vector<Exposure>& bracket, const std::vector<int64_t>& pix, int c,
                                   const ResponseOptions& o, const std::vector<double>& start) {
  const int L = o.levels;
  auto weight = [&](int k) {
    const double z = (k + 0.5) / L - 0.5;
    return (k == 0 || k == L - 1) ? 0.0 : std::exp(-16.0 * z * z);
  };
  std::vector<double> X(static_cast<size_t>(L));
  for (int k = 0; k < L; ++k) X[static_cast<size_t>(k)] = std::exp(start[static_cast<size_t>(k)]);
  const size_t m = bracket.size();
  std::vector<int> level(pix.size() * m);
  for (size_t i = 0; i < pix.size(); ++i)
    for (size_t j = 0; j < m; ++j) {
      const Exposure& e = bracket[j];
      level[i * m + j] = Level(e.codes.values()[static_cast<size_t>(pix[i] * e.codes.channels() + c)], L);
    }
  std::vector<double> E(pix.size());
  for (int it = 0; it < o.iterations; ++it) {
    for (size_t i = 0; i < pix.size(); ++i) {
      double num = 0, den = 0;
      for (size_t j = 0; j < m; ++j) {
        const int k = level[i * m + j];
        const double w = weight(k), t = bracket[j].time_s;
        num += w * t * X[static_cast<size_t>(k)];
        den += w * t * t;
      }
      E[i] = den > 0 ? num / den : 0;
    }
    std::vector<double> sum(static_cast<size_t>(L), 0.0);
    std::vector<int> count(static_cast<size_t>(L), 0);
    for (size_t i = 0; i < pix.size(); ++i) {
      if (!(E[i] > 0)) continue;
      for (size_t j = 0; j < m; ++j) {
        const int k = level[i * m + j];
        sum[static_cast<size_t>(k)] += E[i] * bracket[j].time_s;
        ++count[static_cast<size_t>(k)];
      }
    }
    for (int k = 0; k < L; ++k)
      if (count[static_cast<size_t>(k)] > 0)
        X[static_cast<size_t>(k)] = sum[static_cast<size_t>(k)] / count[static_cast<size_t>(k)];
    const double mid = X[static_cast<size_t>(L / 2)];
    if (!(mid > 0)) ThrowError("Robertson's response estimate collapsed (no pixel at the middle code)");
    for (double& v : X) v /= mid;
  }
  std::vector<double> g(static_cast<size_t>(L));
  for (int k = 0; k < L; ++k) g[static_cast<size_t>(k)] = std::log(std::max(X[static_cast<size_t>(k)], 1e-12));
  return g;
}

}  // namespace

double CameraResponse::Exposure(int channel, double z) const {
  if (identity) return std::max(z, 0.0);
  const std::vector<double>& g = log_exposure[static_cast<size_t>(channel)];
  const int L = levels();
  const double u = std::clamp(z, 0.0, 1.0) * (L - 1);
  const int k = std::min(static_cast<int>(u), L - 2);
  const double f = u - k;
  return std::exp((1 - f) * g[static_cast<size_t>(k)] + f * g[static_cast<size_t>(k + 1)]);
}

double CameraResponse::ExposureSlope(int channel, double z) const {
  if (identity) return 1.0;
  const std::vector<double>& g = log_exposure[static_cast<size_t>(channel)];
  const int L = levels();
  const double u = std::clamp(z, 0.0, 1.0) * (L - 1);
  const int k = std::min(static_cast<int>(u), L - 2);
  return Exposure(channel, z) * (g[static_cast<size_t>(k + 1)] - g[static_cast<size_t>(k)]) * (L - 1);
}

double CameraResponse::Code(int channel, double exposure) const {
  if (identity) return std::clamp(exposure, 0.0, 1.0);
  if (!(exposure > 0)) return 0;  // also NaN
  const std::vector<double>& g = log_exposure[static_cast<size_t>(channel)];
  const double x = std::log(exposure);
  if (x <= g.front()) return 0;
  if (x >= g.back()) return 1;
  // The first entry above x: g[k-1] <= x < g[k] (g is non-decreasing).
  const size_t k = static_cast<size_t>(std::upper_bound(g.begin(), g.end(), x) - g.begin());
  const double f = (x - g[k - 1]) / (g[k] - g[k - 1]);  // g[k] > x >= g[k-1]: no division by 0
  return (static_cast<double>(k - 1) + f) / (levels() - 1);
}

CameraResponse LinearResponse(int channels, int levels) {
  CameraResponse r;
  r.method = "linear";
  r.identity = true;
  const char* names[] = {"R", "G", "B"};
  for (int c = 0; c < channels; ++c) {
    r.channels.push_back(c < 3 ? names[c] : fmt::format("C{}", c));
    std::vector<double> g(static_cast<size_t>(levels));
    // Level 0 stands for code 0: a tiny positive exposure keeps ln finite;
    // interpolation towards it is linear in ln, which only matters below
    // one table step.
    for (int k = 0; k < levels; ++k)
      g[static_cast<size_t>(k)] = std::log(std::max(static_cast<double>(k), 1e-3) / (levels - 1));
    r.log_exposure.push_back(g);
  }
  return r;
}

CameraResponse SrgbResponse(int channels, int levels) {
  CameraResponse r = LinearResponse(channels, levels);
  r.method = "srgb";
  r.identity = false;
  for (auto& g : r.log_exposure)
    for (int k = 0; k < levels; ++k)
      g[static_cast<size_t>(k)] = std::log(
          std::max(static_cast<double>(SrgbToLinear(static_cast<float>(k) / (levels - 1))), 1e-3 / (levels - 1)));
  return r;
}

void ResponseOptions::Check() const {
  if (method != "debevec" && method != "robertson")
    throw UsageError(fmt::format("response method \"{}\" is not debevec or robertson", method));
  if (levels < 16 || levels > 4096) throw UsageError(fmt::format("response levels {} not in [16, 4096]", levels));
  if (!(smoothness >= 0)) throw UsageError("response smoothness must be >= 0");
  if (samples < 32) throw UsageError("at least 32 response samples");
}

CameraResponse RecoverResponse(const std::vector<Exposure>& bracket, const ResponseOptions& o, ResponseReport* report) {
  o.Check();
  CheckBracket(bracket);
  std::vector<Exposure> sorted = bracket;
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const Exposure& a, const Exposure& b) { return a.time_s < b.time_s; });
  for (const Exposure& e : sorted)
    if (e.pixel_type == "float" || e.pixel_type == "half")
      ThrowError("{}: a response is recovered from integer codes; {} pixels are already linear", e.name, e.pixel_type);
  CameraResponse r;
  r.method = o.method;
  r.channels = sorted[0].codes.channel_names();
  ResponseReport rep;
  const std::vector<int64_t> pix =
      o.method == "debevec" ? ChooseDebevecSamples(sorted, o.samples) : CandidatePixels(sorted, 20000);
  if (pix.size() < 16) ThrowError("only {} usable pixels for the response (need 16)", pix.size());
  rep.samples = static_cast<int>(pix.size());
  double rms = 0;
  for (int c = 0; c < sorted[0].codes.channels(); ++c) {
    std::vector<double> g;
    if (o.method == "debevec") {
      double rc = 0;
      g = SolveDebevec(sorted, pix, c, o, &rc);
      rms += rc * rc;
    } else {
      double rc = 0;
      g = SolveRobertson(sorted, pix, c, o, SolveDebevec(sorted, ChooseDebevecSamples(sorted, o.samples), c, o, &rc));
      rep.iterations = o.iterations;
    }
    for (double v : g)
      if (!std::isfinite(v)) ThrowError("the recovered response is not finite (too few distinct exposures?)");
    rep.monotonicity_fixes += MakeIncreasing(&g);
    // The solve fixes g(middle) = 0; the unit is the saturating exposure.
    const double top = g.back();
    for (double& v : g) v -= top;
    r.log_exposure.push_back(std::move(g));
  }
  rep.rms_log = std::sqrt(rms / std::max(1, sorted[0].codes.channels()));
  if (report) *report = rep;
  return r;
}

Json ResponseToJson(const CameraResponse& r) {
  Json ch = Json::object();
  for (size_t c = 0; c < r.channels.size(); ++c) ch[r.channels[c]] = r.log_exposure[c];
  return {{"format", "mr-response"}, {"version", 1},           {"method", r.method},
          {"levels", r.levels()},    {"channels", r.channels}, {"log_exposure", ch}};
}

CameraResponse ParseResponse(const Json& j, const std::string& name) {
  JsonSettings root(JsonNode(j, "", &name));
  root.Header("mr-response", "response");
  const JsonNode method = root.Require("method");
  const JsonNode levels_node = root.Require("levels");
  const JsonNode chs = root.Require("channels");
  const JsonNode tables = root.Require("log_exposure");
  root.Take("comment");
  root.Done();
  CameraResponse r;
  r.method = method.String();
  r.identity = r.method == "linear";
  const int levels = static_cast<int>(levels_node.Integer(16, 4096));
  if (!chs.json().is_array() || chs.json().empty()) chs.Fail("expected a non-empty array of channel names");
  for (size_t i = 0; i < chs.json().size(); ++i) r.channels.push_back(chs.Index(i).String());
  if (!tables.json().is_object()) tables.Fail("expected an object of tables by channel");
  if (tables.json().size() != r.channels.size()) tables.Fail("expected one table per channel");
  for (const std::string& c : r.channels) {
    if (!tables.Has(c.c_str())) tables.Fail(fmt::format("no table for channel {}", c));
    const std::vector<double> g = tables.Child(c).Numbers(static_cast<size_t>(levels), -1e3, 1e3);
    for (size_t k = 1; k < g.size(); ++k)
      if (!(g[k] > g[k - 1]))
        tables.Child(c).Fail(fmt::format("the table must increase (entry {} is {} after {})", k, g[k], g[k - 1]));
    r.log_exposure.push_back(g);
  }
  return r;
}

void WriteResponse(const fs::path& path, const CameraResponse& r, const std::string& provenance) {
  Json j = ResponseToJson(r);
  if (!provenance.empty()) j["comment"] = provenance;
  WriteTextFile(path, j.dump(1) + "\n");
}

CameraResponse ReadResponse(const fs::path& path) { return ParseResponse(ReadJsonFile(path), path.string()); }

namespace {

// `f(channel, value)` applied to every value of `img`, channel by channel.
template <class F>
Image PerChannel(const Image& img, const CameraResponse& r, F f) {
  if (static_cast<int>(r.channels.size()) != img.channels())
    ThrowError("the response has {} channels, the image {}", r.channels.size(), img.channels());
  Image out(img.width(), img.height(), img.channel_names());
  const size_t nc = static_cast<size_t>(img.channels());
  for (size_t i = 0; i < img.values().size(); ++i)
    out.values()[i] = static_cast<float>(f(static_cast<int>(i % nc), img.values()[i]));
  return out;
}

}  // namespace

Image Linearise(const Image& codes, const CameraResponse& r) {
  return PerChannel(codes, r, [&r](int c, double z) { return r.Exposure(c, z); });
}

Image Delinearise(const Image& exposures, const CameraResponse& r) {
  return PerChannel(exposures, r, [&r](int c, double x) { return r.Code(c, x); });
}

}  // namespace mr
