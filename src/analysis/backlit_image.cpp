#include "analysis/backlit_image.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "analysis/centroid_angle.hpp"
#include "core/error.hpp"

namespace biodem::analysis {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Circle {
  double cx, cy, r;
};

// Circle through three points (false if they are nearly collinear).
bool circle_through(const cv::Point2d& a, const cv::Point2d& b, const cv::Point2d& c, Circle& out) {
  const double d = 2.0 * (a.x * (b.y - c.y) + b.x * (c.y - a.y) + c.x * (a.y - b.y));
  if (std::abs(d) < 1e-9) return false;
  const double a2 = a.dot(a), b2 = b.dot(b), c2 = c.dot(c);
  out.cx = (a2 * (b.y - c.y) + b2 * (c.y - a.y) + c2 * (a.y - b.y)) / d;
  out.cy = (a2 * (c.x - b.x) + b2 * (a.x - c.x) + c2 * (b.x - a.x)) / d;
  out.r = std::hypot(a.x - out.cx, a.y - out.cy);
  return true;
}

// Algebraic least-squares circle (Kasa): x^2 + y^2 + D x + E y + F = 0.
bool fit_circle(const std::vector<cv::Point2d>& p, Circle& out) {
  if (p.size() < 3) return false;
  cv::Matx33d A = cv::Matx33d::zeros();
  cv::Vec3d b(0, 0, 0);
  for (const auto& q : p) {
    const cv::Vec3d row(q.x, q.y, 1.0);
    const double rhs = -(q.x * q.x + q.y * q.y);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) A(i, j) += row[i] * row[j];
      b[i] += row[i] * rhs;
    }
  }
  cv::Vec3d s;
  if (!cv::solve(A, b, s, cv::DECOMP_SVD)) return false;
  out.cx = -s[0] / 2.0;
  out.cy = -s[1] / 2.0;
  const double r2 = out.cx * out.cx + out.cy * out.cy - s[2];
  if (!(r2 > 0.0)) return false;
  out.r = std::sqrt(r2);
  return true;
}

// Small deterministic generator: the disc found must not depend on a global random state.
struct Lcg {
  std::uint64_t s = 0x9E3779B97F4A7C15ull;
  std::size_t below(std::size_t n) {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<std::size_t>((s >> 33) % n);
  }
};

}  // namespace

int otsu_threshold(const cv::Mat& gray, const cv::Mat& mask, double* mean_dark,
                   double* mean_bright) {
  std::array<double, 256> hist{};
  double total = 0.0;
  for (int i = 0; i < gray.rows; ++i) {
    const auto* g = gray.ptr<std::uint8_t>(i);
    const auto* m = mask.ptr<std::uint8_t>(i);
    for (int j = 0; j < gray.cols; ++j)
      if (m[j]) {
        hist[g[j]] += 1.0;
        total += 1.0;
      }
  }
  double sum_all = 0.0;
  for (int t = 0; t < 256; ++t) sum_all += t * hist[static_cast<std::size_t>(t)];
  double w0 = 0.0, sum0 = 0.0, best = -1.0;
  int best_t = 0;
  double best_m0 = kNaN, best_m1 = kNaN;
  for (int t = 0; t < 255; ++t) {
    w0 += hist[static_cast<std::size_t>(t)];
    sum0 += t * hist[static_cast<std::size_t>(t)];
    const double w1 = total - w0;
    if (w0 <= 0.0 || w1 <= 0.0) continue;
    const double m0 = sum0 / w0, m1 = (sum_all - sum0) / w1;
    const double between = w0 * w1 * (m0 - m1) * (m0 - m1);
    if (between > best) {
      best = between;
      best_t = t;
      best_m0 = m0;
      best_m1 = m1;
    }
  }
  if (mean_dark) *mean_dark = best_m0;
  if (mean_bright) *mean_bright = best_m1;
  return best_t;
}

DrumDisc find_drum_disc(const cv::Mat& gray) {
  if (gray.empty() || gray.type() != CV_8UC1) throw Error("drum disc: not a grey 8-bit image");
  cv::Mat blurred, bright;
  cv::GaussianBlur(gray, blurred, cv::Size(5, 5), 0.0);
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(blurred, &lo, &hi);
  if (hi - lo < 30.0)
    throw Error("could not find the drum disc: the image has no contrast (give --center-px and "
                "--radius-px)");
  cv::threshold(blurred, bright, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);

  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(bright, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  const double image_area = static_cast<double>(gray.rows) * gray.cols;
  std::size_t best = contours.size();
  double best_area = 0.0;
  for (std::size_t k = 0; k < contours.size(); ++k) {
    const double a = cv::contourArea(contours[k]);
    if (a > best_area) {
      best_area = a;
      best = k;
    }
  }
  if (best == contours.size() || best_area < 0.01 * image_area)
    throw Error("could not find the drum disc: no bright region (give --center-px and "
                "--radius-px)");

  // Contour points not on the image border (a cropped disc is cut by a straight edge).
  std::vector<cv::Point2d> pts;
  for (const auto& q : contours[best])
    if (q.x > 0 && q.y > 0 && q.x < gray.cols - 1 && q.y < gray.rows - 1)
      pts.emplace_back(q.x, q.y);
  if (pts.size() < 20) throw Error("could not find the drum disc: its outline is too short");
  const double r_min = 0.05 * std::min(gray.rows, gray.cols);
  const double r_max = 2.0 * std::hypot(gray.rows, gray.cols);

  auto inliers_of = [&](const Circle& c, std::vector<cv::Point2d>* out) {
    const double tol = std::max(2.0, 0.01 * c.r);
    std::size_t n = 0;
    for (const auto& q : pts)
      if (std::abs(std::hypot(q.x - c.cx, q.y - c.cy) - c.r) <= tol) {
        ++n;
        if (out) out->push_back(q);
      }
    return n;
  };

  Lcg rng;
  Circle best_c{0, 0, 0};
  std::size_t best_n = 0;
  const std::size_t m = pts.size();
  for (int it = 0; it < 400; ++it) {
    // Three points spread along the contour make well-conditioned circles.
    const std::size_t i0 = rng.below(m);
    const std::size_t i1 = (i0 + m / 6 + rng.below(std::max<std::size_t>(1, m / 3))) % m;
    const std::size_t i2 = (i1 + m / 6 + rng.below(std::max<std::size_t>(1, m / 3))) % m;
    Circle c;
    if (!circle_through(pts[i0], pts[i1], pts[i2], c) || c.r < r_min || c.r > r_max) continue;
    const std::size_t n = inliers_of(c, nullptr);
    if (n > best_n) {
      best_n = n;
      best_c = c;
    }
  }
  if (best_n < 20) throw Error("could not find the drum disc: the bright region is not round");
  for (int refine = 0; refine < 2; ++refine) {
    std::vector<cv::Point2d> in;
    inliers_of(best_c, &in);
    Circle c;
    if (!fit_circle(in, c)) break;
    best_c = c;
  }

  // The rim must be seen over a good part of the circle, not a short arc.
  std::vector<cv::Point2d> in;
  inliers_of(best_c, &in);
  std::array<bool, 36> sector{};
  for (const auto& q : in) {
    const double a = std::atan2(q.y - best_c.cy, q.x - best_c.cx);
    const auto k = static_cast<std::size_t>(std::clamp((a + std::numbers::pi) / (2.0 * std::numbers::pi) * 36.0, 0.0, 35.0));
    sector[k] = true;
  }
  // A dense bed touching the rim hides part of it and adds a long, jagged surface outline, so
  // the arc may be a minority of the outline points: require one unbroken arc of at least
  // 120 deg (12 of 36 sectors, wrapping round) and 1/8 of the points. A square or a blob gives
  // inliers in short separate clusters only.
  std::size_t longest = 0;
  for (std::size_t start = 0; start < sector.size(); ++start) {
    std::size_t run = 0;
    while (run < sector.size() && sector[(start + run) % sector.size()]) ++run;
    longest = std::max(longest, run);
  }
  if (longest < 12 || in.size() < pts.size() / 8)
    throw Error("could not find the drum disc: no circular outline (give --center-px and "
                "--radius-px)");
  return DrumDisc{best_c.cx, best_c.cy, best_c.r};
}

cv::Mat disc_mask(cv::Size size, const DrumDisc& disc, double margin_px) {
  cv::Mat m(size, CV_8UC1, cv::Scalar(0));
  const double r = disc.radius_px - margin_px;
  if (r <= 0.0) return m;
  const double r2 = r * r;
  for (int i = 0; i < size.height; ++i) {
    auto* p = m.ptr<std::uint8_t>(i);
    const double dy = i - disc.cy_px;
    for (int j = 0; j < size.width; ++j) {
      const double dx = j - disc.cx_px;
      if (dx * dx + dy * dy <= r2) p[j] = 255;
    }
  }
  return m;
}

namespace {
double rim_margin(const FrameParams& p, const DrumDisc& d) {
  return p.rim_margin_px < 0.0 ? std::max(1.5, 0.005 * d.radius_px) : p.rim_margin_px;
}
}  // namespace

namespace {

// Bounding box of the disc, clipped to the image.
cv::Rect disc_box(cv::Size size, const DrumDisc& d) {
  const int x0 = std::max(0, static_cast<int>(std::floor(d.cx_px - d.radius_px)));
  const int y0 = std::max(0, static_cast<int>(std::floor(d.cy_px - d.radius_px)));
  const int x1 = std::min(size.width, static_cast<int>(std::ceil(d.cx_px + d.radius_px)) + 1);
  const int y1 = std::min(size.height, static_cast<int>(std::ceil(d.cy_px + d.radius_px)) + 1);
  return cv::Rect(x0, y0, std::max(0, x1 - x0), std::max(0, y1 - y0));
}

constexpr int kTerms = 7;  // 1, u, v, u^2, uv, v^2, r^4 (u, v = offsets from the centre / R)

std::array<double, kTerms> basis(double u, double v) {
  const double r2 = u * u + v * v;
  return {1.0, u, v, u * u, u * v, v * v, r2 * r2};
}

// Least-squares fit of the basis to the samples (u, v, grey) whose `use` flag is set.
bool fit_light(const std::vector<std::array<double, 3>>& s, const std::vector<char>& use,
               std::array<double, kTerms>& coef) {
  cv::Mat A = cv::Mat::zeros(kTerms, kTerms, CV_64F), b = cv::Mat::zeros(kTerms, 1, CV_64F);
  std::size_t n = 0;
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (!use[k]) continue;
    ++n;
    const auto f = basis(s[k][0], s[k][1]);
    for (int i = 0; i < kTerms; ++i) {
      b.at<double>(i) += f[static_cast<std::size_t>(i)] * s[k][2];
      for (int j = 0; j < kTerms; ++j)
        A.at<double>(i, j) += f[static_cast<std::size_t>(i)] * f[static_cast<std::size_t>(j)];
    }
  }
  if (n < 4 * kTerms) return false;
  cv::Mat x;
  if (!cv::solve(A, b, x, cv::DECOMP_SVD)) return false;
  for (int i = 0; i < kTerms; ++i) coef[static_cast<std::size_t>(i)] = x.at<double>(i);
  return true;
}

double eval_light(const std::array<double, kTerms>& c, double u, double v) {
  const auto f = basis(u, v);
  double y = 0.0;
  for (std::size_t i = 0; i < f.size(); ++i) y += c[i] * f[i];
  return y;
}

}  // namespace

cv::Mat background_illumination(const cv::Mat& gray, const DrumDisc& disc) {
  cv::Mat f;
  gray.convertTo(f, CV_32F);
  const double sigma = std::max(1.0, disc.radius_px / 200.0);
  cv::GaussianBlur(f, f, cv::Size(0, 0), sigma);
  cv::max(f, 1.0, f);
  return f;
}

cv::Mat estimate_illumination(const cv::Mat& gray, const DrumDisc& disc, double margin_px) {
  const double margin = margin_px < 0.0 ? std::max(1.5, 0.005 * disc.radius_px) : margin_px;
  const double R = disc.radius_px;
  const double r_in = std::max(1.0, R - margin - 1.0);
  // Samples on a grid of about 150 x 150 over the disc: enough for 7 coefficients, cheap per frame.
  const int step = std::max(1, static_cast<int>(R / 75.0));
  const cv::Rect box = disc_box(gray.size(), disc);
  std::vector<std::array<double, 3>> s;
  std::array<double, 256> hist{};
  for (int i = box.y; i < box.y + box.height; i += step) {
    const auto* g = gray.ptr<std::uint8_t>(i);
    for (int j = box.x; j < box.x + box.width; j += step) {
      const double u = (j - disc.cx_px) / R, v = (i - disc.cy_px) / R;
      if (std::hypot(u, v) * R > r_in) continue;
      s.push_back({u, v, static_cast<double>(g[j])});
      hist[g[j]] += 1.0;
    }
  }
  cv::Mat light(gray.size(), CV_32F, cv::Scalar(1.0f));
  if (s.empty()) return light;
  // Lit pixels: above Otsu's threshold of the samples when the two classes are clearly apart
  // (powder passes less than half the light); otherwise the whole disc is lit (an empty drum,
  // where the split would only cut the vignetting in two).
  double total = 0.0, sum_all = 0.0;
  for (int t = 0; t < 256; ++t) {
    total += hist[static_cast<std::size_t>(t)];
    sum_all += t * hist[static_cast<std::size_t>(t)];
  }
  double w0 = 0.0, sum0 = 0.0, best = -1.0, m0 = kNaN, m1 = kNaN;
  int t_otsu = 0;
  for (int t = 0; t < 255; ++t) {
    w0 += hist[static_cast<std::size_t>(t)];
    sum0 += t * hist[static_cast<std::size_t>(t)];
    const double w1 = total - w0;
    if (w0 <= 0.0 || w1 <= 0.0) continue;
    const double a0 = sum0 / w0, a1 = (sum_all - sum0) / w1;
    const double between = w0 * w1 * (a0 - a1) * (a0 - a1);
    if (between > best) {
      best = between;
      t_otsu = t;
      m0 = a0;
      m1 = a1;
    }
  }
  std::array<double, kTerms> coef{};
  std::vector<char> use(s.size(), 1);
  if (m0 < 0.5 * m1)
    for (std::size_t k = 0; k < s.size(); ++k) use[k] = s[k][2] > t_otsu;
  bool ok = fit_light(s, use, coef);
  if (ok) {
    for (std::size_t k = 0; k < s.size(); ++k) use[k] = s[k][2] > 0.7 * eval_light(coef, s[k][0], s[k][1]);
    std::array<double, kTerms> refined{};
    if (fit_light(s, use, refined)) coef = refined;
  } else {
    // Too few lit samples to fit a surface (a nearly full drum): a uniform light at their mean.
    double sum = 0.0, n = 0.0;
    for (std::size_t k = 0; k < s.size(); ++k)
      if (use[k]) {
        sum += s[k][2];
        n += 1.0;
      }
    coef = {};
    coef[0] = n > 0.0 ? sum / n : 255.0;
  }
  // Evaluated row by row: for a fixed v the surface is a polynomial in u.
  for (int i = box.y; i < box.y + box.height; ++i) {
    auto* l = light.ptr<float>(i);
    const double v = (i - disc.cy_px) / R, v2 = v * v;
    const double c0 = coef[0] + coef[2] * v + coef[5] * v2;
    const double c1 = coef[1] + coef[4] * v;
    for (int j = box.x; j < box.x + box.width; ++j) {
      const double u = (j - disc.cx_px) / R, u2 = u * u, r2 = u2 + v2;
      l[j] = static_cast<float>(std::max(1.0, c0 + c1 * u + coef[3] * u2 + coef[6] * r2 * r2));
    }
  }
  return light;
}

cv::Mat flat_field(const cv::Mat& gray, const cv::Mat& illumination) {
  if (illumination.size() != gray.size() || illumination.type() != CV_32F)
    throw Error("flat field: the background differs in size from the frame");
  cv::Mat g, out;
  gray.convertTo(g, CV_32F);
  cv::divide(g, illumination, g, kLitLevel);
  g.convertTo(out, CV_8U);  // saturates
  return out;
}

cv::Mat powder_mask(const cv::Mat& gray, const DrumDisc& disc, const FrameParams& params,
                    int* threshold_used, double* bed_light) {
  const cv::Mat inside = disc_mask(gray.size(), disc, rim_margin(params, disc));
  if (bed_light) *bed_light = kNaN;
  int t;
  cv::Mat dark, corrected;
  if (params.threshold) {
    t = *params.threshold;
    cv::compare(gray, cv::Scalar(t), dark, cv::CMP_LE);
  } else {
    const cv::Mat light = params.illumination.empty()
                              ? estimate_illumination(gray, disc, rim_margin(params, disc))
                              : params.illumination;
    corrected = flat_field(gray, light);
    double m0 = kNaN, m1 = kNaN;
    t = otsu_threshold(corrected, inside, &m0, &m1);
    if (!(m1 - m0 >= params.min_contrast)) t = -1;  // uniform disc: no powder
    if (t >= 0) cv::compare(corrected, cv::Scalar(t), dark, cv::CMP_LE);
  }
  if (threshold_used) *threshold_used = t;
  cv::Mat mask(gray.size(), CV_8UC1, cv::Scalar(0));
  if (t < 0) return mask;
  dark.copyTo(mask, inside);

  // Morphological cleaning: opening removes isolated dark pixels (noise, JPEG ringing, small
  // dust), closing fills pinholes of light inside the bed; both with an elliptical kernel small
  // against the bed (R / 80: 3 px for a 250 px disc).
  int k = params.clean_px;
  if (k < 0) k = std::max(3, static_cast<int>(disc.radius_px / 80.0) | 1);
  if (k > 0) {
    const cv::Mat el = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(k, k));
    cv::morphologyEx(mask, mask, cv::MORPH_OPEN, el);
    cv::morphologyEx(mask, mask, cv::MORPH_CLOSE, el);
    mask &= inside;
  }
  // The bed is the largest connected dark region: larger dust specks on the end plates and
  // grains in flight are not powder of the bed.
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  int bed = -1, area = 0;
  for (int l = 1; l < n; ++l)
    if (stats.at<int>(l, cv::CC_STAT_AREA) > area) {
      area = stats.at<int>(l, cv::CC_STAT_AREA);
      bed = l;
    }
  const double disc_area = std::numbers::pi * disc.radius_px * disc.radius_px;
  if (bed < 0 || area < params.min_bed_fraction * disc_area) {
    mask.setTo(cv::Scalar(0));
    return mask;
  }
  if (n > 2) cv::compare(labels, cv::Scalar(bed), mask, cv::CMP_EQ);
  // Light enclosed by the bed (a dust speck in front of the powder divided out by the flat field,
  // a gap between grains) is not free surface: the bed's holes are filled.
  std::vector<std::vector<cv::Point>> outline;
  cv::findContours(mask.clone(), outline, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  cv::drawContours(mask, outline, -1, cv::Scalar(255), cv::FILLED);
  if (bed_light && !corrected.empty()) *bed_light = cv::mean(corrected, mask)[0] / kLitLevel;
  return mask;
}

double mask_centroid_angle_deg(const cv::Mat& mask, const DrumDisc& disc, Rotation rotation) {
  const cv::Moments mo = cv::moments(mask, true);
  if (mo.m00 <= 0.0) return kNaN;
  double xc = mo.m10 / mo.m00 - disc.cx_px;
  const double yc = disc.cy_px - mo.m01 / mo.m00;  // y up
  if (rotation == Rotation::cw) xc = -xc;
  return centroid_angle_deg(xc, yc);
}

FrameMeasure measure_backlit_frame(const cv::Mat& gray, const DrumDisc& disc,
                                   const FrameParams& params) {
  FrameMeasure fm;
  fm.alpha_deg = kNaN;
  fm.surface = SurfaceFit{kNaN, kNaN, 0, false};
  const cv::Mat mask = powder_mask(gray, disc, params, &fm.threshold, &fm.bed_light);
  fm.powder_px = static_cast<std::size_t>(cv::countNonZero(mask));
  if (fm.powder_px == 0) return fm;
  fm.has_powder = true;
  fm.alpha_deg = mask_centroid_angle_deg(mask, disc, params.rotation);
  ImageSurfaceParams sp = params.surface;
  sp.mirror_x = params.rotation == Rotation::cw;
  fm.surface = fit_free_surface_mask(mask, disc.cx_px, disc.cy_px, disc.radius_px, sp);
  return fm;
}

}  // namespace biodem::analysis
