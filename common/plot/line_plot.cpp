#include "common/plot/line_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/core/error.h"

namespace nsim {
namespace {

constexpr int kMarginLeft = 86;    // tick labels and the rotated y label (px)
constexpr int kMarginRight = 20;   // (px)
constexpr int kMarginTop = 36;     // title (px)
constexpr int kMarginBottom = 52;  // tick labels and the x label (px)
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kTickFontScale = 0.42;
constexpr double kLabelFontScale = 0.5;
constexpr double kTitleFontScale = 0.6;
constexpr int kShift = 4;  // sub-pixel bits of the drawing calls
const cv::Scalar kBackground(255, 255, 255);
const cv::Scalar kAxisColor(40, 40, 40);
const cv::Scalar kGridColor(225, 225, 225);
const cv::Scalar kTextColor(20, 20, 20);

// fills empty or degenerate ranges from the data
void ResolveRange(double* lo, double* hi, double pad_fraction) {
  if (!std::isfinite(*lo) || !std::isfinite(*hi)) {
    *lo = 0.0;
    *hi = 1.0;
    return;
  }
  if (*hi - *lo <= 0) {
    const double d = *lo != 0 ? std::abs(*lo) * 0.1 : 1.0;
    *lo -= d;
    *hi += d;
    return;
  }
  const double pad = (*hi - *lo) * pad_fraction;
  *lo -= pad;
  *hi += pad;
}

std::string FormatTick(double v, double step) {
  const int decimals = std::max(0, -static_cast<int>(std::floor(std::log10(step) + 1e-9)));
  if (std::abs(v) < 1e-12 * step) v = 0.0;  // no "-0"
  char text[64];
  if (std::abs(v) >= 1e6 || (v != 0 && std::abs(v) < 1e-4 && decimals > 6))
    std::snprintf(text, sizeof(text), "%.3g", v);
  else
    std::snprintf(text, sizeof(text), "%.*f", decimals, v);
  return text;
}

cv::Point Fixed(const cv::Point2d& p) {  // sub-pixel point for kShift drawing
  return cv::Point(static_cast<int>(std::lround(p.x * (1 << kShift))),
                   static_cast<int>(std::lround(p.y * (1 << kShift))));
}

void PutText(cv::Mat& img, const std::string& text, cv::Point origin, double scale) {
  cv::putText(img, text, origin, kFont, scale, kTextColor, 1, cv::LINE_AA);
}

cv::Size TextSize(const std::string& text, double scale) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, scale, 1, &baseline);
}

}  // namespace

void PlotConfig::Validate() const {
  if (width < 240) throw InputError(Str("plot.width must be >= 240 px, got ", width));
  if (height < 160) throw InputError(Str("plot.height must be >= 160 px, got ", height));
  if (std::isfinite(x_min) && std::isfinite(x_max) && !(x_max > x_min))
    throw InputError(Str("plot.x_max must be > x_min (", x_min, "), got ", x_max));
  if (std::isfinite(y_min) && std::isfinite(y_max) && !(y_max > y_min))
    throw InputError(Str("plot.y_max must be > y_min (", y_min, "), got ", y_max));
}

LinePlot::LinePlot(PlotConfig config) : config_(std::move(config)) { config_.Validate(); }

LinePlot& LinePlot::Add(PlotSeries series) {
  if (series.x.size() != series.y.size())
    throw InputError(Str("plot series '", series.label, "': ", series.x.size(), " x values but ",
                         series.y.size(), " y values"));
  if (series.thickness < 1 || series.thickness > 10)
    throw InputError(Str("plot series '", series.label, "': thickness must be in [1, 10] px, got ",
                         series.thickness));
  if (series.color[0] < 0 || series.color[1] < 0 || series.color[2] < 0)
    series.color = PaletteColor(static_cast<int>(series_.size()));
  series_.push_back(std::move(series));
  return *this;
}

LinePlot& LinePlot::Add(const std::string& label, std::vector<double> x, std::vector<double> y) {
  PlotSeries s;
  s.label = label;
  s.x = std::move(x);
  s.y = std::move(y);
  return Add(std::move(s));
}

cv::Rect LinePlot::plot_area() const {
  return cv::Rect(kMarginLeft, kMarginTop, config_.width - kMarginLeft - kMarginRight,
                  config_.height - kMarginTop - kMarginBottom);
}

cv::Vec4d LinePlot::Ranges() const {
  double x_lo = config_.x_min, x_hi = config_.x_max, y_lo = config_.y_min, y_hi = config_.y_max;
  double dx_lo = INFINITY, dx_hi = -INFINITY, dy_lo = INFINITY, dy_hi = -INFINITY;
  for (const auto& s : series_) {
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      dx_lo = std::min(dx_lo, s.x[i]);
      dx_hi = std::max(dx_hi, s.x[i]);
      // y range only over points inside a fixed x range
      if (std::isfinite(config_.x_min) && s.x[i] < config_.x_min) continue;
      if (std::isfinite(config_.x_max) && s.x[i] > config_.x_max) continue;
      dy_lo = std::min(dy_lo, s.y[i]);
      dy_hi = std::max(dy_hi, s.y[i]);
    }
  }
  if (!std::isfinite(x_lo) || !std::isfinite(x_hi)) {
    double lo = std::isfinite(x_lo) ? x_lo : dx_lo, hi = std::isfinite(x_hi) ? x_hi : dx_hi;
    ResolveRange(&lo, &hi, 0.0);
    x_lo = lo;
    x_hi = hi;
  }
  if (!std::isfinite(y_lo) || !std::isfinite(y_hi)) {
    double lo = std::isfinite(y_lo) ? y_lo : dy_lo, hi = std::isfinite(y_hi) ? y_hi : dy_hi;
    // pad only the data-derived ends
    const bool fixed_lo = std::isfinite(y_lo), fixed_hi = std::isfinite(y_hi);
    double plo = lo, phi = hi;
    ResolveRange(&plo, &phi, 0.05);
    y_lo = fixed_lo ? lo : plo;
    y_hi = fixed_hi ? hi : phi;
    if (!(y_hi > y_lo)) y_hi = y_lo + 1.0;
  }
  return cv::Vec4d(x_lo, x_hi, y_lo, y_hi);
}

cv::Point2d LinePlot::ToPixel(double x, double y) const {
  const cv::Vec4d r = Ranges();
  const cv::Rect a = plot_area();
  return cv::Point2d(a.x + (x - r[0]) / (r[1] - r[0]) * (a.width - 1),
                     a.y + (r[3] - y) / (r[3] - r[2]) * (a.height - 1));
}

cv::Mat LinePlot::Render() const {
  cv::Mat img(config_.height, config_.width, CV_8UC3, kBackground);
  const cv::Rect area = plot_area();
  const cv::Vec4d r = Ranges();
  auto px = [&](double x, double y) {
    return cv::Point2d(area.x + (x - r[0]) / (r[1] - r[0]) * (area.width - 1),
                       area.y + (r[3] - y) / (r[3] - r[2]) * (area.height - 1));
  };

  // grid and tick labels
  const int max_x_ticks = std::max(2, area.width / 90), max_y_ticks = std::max(2, area.height / 45);
  const std::vector<double> x_ticks = NiceTicks(r[0], r[1], max_x_ticks);
  const std::vector<double> y_ticks = NiceTicks(r[2], r[3], max_y_ticks);
  const double x_step = x_ticks.size() > 1 ? x_ticks[1] - x_ticks[0] : r[1] - r[0];
  const double y_step = y_ticks.size() > 1 ? y_ticks[1] - y_ticks[0] : r[3] - r[2];
  for (double xt : x_ticks) {
    const cv::Point2d p = px(xt, r[2]);
    if (config_.grid)
      cv::line(img, Fixed({p.x, double(area.y)}), Fixed({p.x, double(area.br().y - 1)}), kGridColor,
               1, cv::LINE_AA, kShift);
    cv::line(img, Fixed({p.x, double(area.br().y)}), Fixed({p.x, double(area.br().y + 5)}),
             kAxisColor, 1, cv::LINE_AA, kShift);
    const std::string text = FormatTick(xt, x_step);
    const cv::Size size = TextSize(text, kTickFontScale);
    PutText(img, text,
            cv::Point(static_cast<int>(p.x) - size.width / 2, area.br().y + 8 + size.height),
            kTickFontScale);
  }
  for (double yt : y_ticks) {
    const cv::Point2d p = px(r[0], yt);
    if (config_.grid)
      cv::line(img, Fixed({double(area.x), p.y}), Fixed({double(area.br().x - 1), p.y}), kGridColor,
               1, cv::LINE_AA, kShift);
    cv::line(img, Fixed({double(area.x - 5), p.y}), Fixed({double(area.x), p.y}), kAxisColor, 1,
             cv::LINE_AA, kShift);
    const std::string text = FormatTick(yt, y_step);
    const cv::Size size = TextSize(text, kTickFontScale);
    PutText(img, text, cv::Point(area.x - 8 - size.width, static_cast<int>(p.y) + size.height / 2),
            kTickFontScale);
  }

  // series, clipped to the axes area by drawing into its ROI
  cv::Mat roi = img(area);
  for (const auto& s : series_) {
    std::vector<cv::Point> segment;
    auto flush = [&]() {
      if (segment.size() >= 2)
        cv::polylines(roi, segment, false, s.color, s.thickness, cv::LINE_AA, kShift);
      else if (segment.size() == 1)
        cv::circle(roi, segment[0], s.thickness * (1 << kShift), s.color, cv::FILLED, cv::LINE_AA,
                   kShift);
      segment.clear();
    };
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
        flush();
        continue;
      }
      const cv::Point2d p = px(s.x[i], s.y[i]) - cv::Point2d(area.x, area.y);
      // keep far-away points within a range OpenCV's fixed-point clipping handles
      const double limit = 4.0 * std::max(area.width, area.height);
      segment.push_back(Fixed({std::clamp(p.x, -limit, limit), std::clamp(p.y, -limit, limit)}));
    }
    flush();
  }
  cv::rectangle(img, area, kAxisColor, 1);

  // labels and title
  if (!config_.x_label.empty()) {
    const cv::Size size = TextSize(config_.x_label, kLabelFontScale);
    PutText(img, config_.x_label,
            cv::Point(area.x + (area.width - size.width) / 2, config_.height - 8), kLabelFontScale);
  }
  if (!config_.y_label.empty()) {
    const cv::Size size = TextSize(config_.y_label, kLabelFontScale);
    cv::Mat label(size.height + 8, size.width + 4, CV_8UC3, kBackground);
    PutText(label, config_.y_label, cv::Point(2, size.height + 2), kLabelFontScale);
    cv::Mat rotated;
    cv::rotate(label, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
    const int x0 = 4;
    const int y0 = std::max(0, area.y + (area.height - rotated.rows) / 2);
    const int h = std::min(rotated.rows, config_.height - y0);
    rotated.rowRange(0, h).copyTo(img(cv::Rect(x0, y0, rotated.cols, h)));
  }
  if (!config_.title.empty()) {
    const cv::Size size = TextSize(config_.title, kTitleFontScale);
    PutText(img, config_.title, cv::Point((config_.width - size.width) / 2, 8 + size.height),
            kTitleFontScale);
  }

  // legend, top right inside the axes
  if (config_.legend) {
    int rows = 0, text_width = 0, text_height = 0;
    for (const auto& s : series_) {
      if (s.label.empty()) continue;
      const cv::Size size = TextSize(s.label, kLabelFontScale);
      text_width = std::max(text_width, size.width);
      text_height = std::max(text_height, size.height);
      ++rows;
    }
    if (rows > 0) {
      const int row_h = text_height + 8, swatch = 24;
      const cv::Rect box(area.br().x - text_width - swatch - 26, area.y + 8,
                         text_width + swatch + 18, rows * row_h + 8);
      cv::rectangle(img, box, kBackground, cv::FILLED);
      cv::rectangle(img, box, kAxisColor, 1);
      int row = 0;
      for (const auto& s : series_) {
        if (s.label.empty()) continue;
        const int y = box.y + 4 + row * row_h + row_h / 2;
        cv::line(img, cv::Point(box.x + 6, y), cv::Point(box.x + 6 + swatch, y), s.color,
                 std::max(2, s.thickness), cv::LINE_AA);
        PutText(img, s.label, cv::Point(box.x + 12 + swatch, y + text_height / 2), kLabelFontScale);
        ++row;
      }
    }
  }
  return img;
}

void LinePlot::SavePng(const std::string& path) const { WritePng(path, Render()); }

cv::Scalar PaletteColor(int i) {
  static const cv::Scalar kPalette[] = {{180, 119, 31},  {14, 127, 255},  {44, 160, 44},
                                        {40, 39, 214},   {189, 103, 148}, {75, 86, 140},
                                        {194, 119, 227}, {127, 127, 127}};
  return kPalette[((i % 8) + 8) % 8];
}

std::vector<double> NiceTicks(double lo, double hi, int max_ticks) {
  NSIM_CHECK(std::isfinite(lo) && std::isfinite(hi) && lo < hi && max_ticks >= 2,
             "invalid tick range [", lo, ", ", hi, "]");
  const double raw = (hi - lo) / max_ticks;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  double step = power;
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * power;
    if (step >= raw) break;
  }
  std::vector<double> ticks;
  const double first = std::ceil(lo / step - 1e-9) * step;
  for (int i = 0; first + i * step <= hi + 1e-9 * step; ++i) ticks.push_back(first + i * step);
  return ticks;
}

cv::Mat StackVertically(const std::vector<cv::Mat>& panels) {
  if (panels.empty()) throw InputError("stack: no panels");
  for (const auto& p : panels) {
    if (p.cols != panels[0].cols || p.type() != panels[0].type())
      throw InputError(
          Str("stack: panels differ in width or type (", p.cols, " vs ", panels[0].cols, " px)"));
  }
  cv::Mat out;
  cv::vconcat(panels, out);
  return out;
}

void WritePng(const std::string& path, const cv::Mat& image) {
  bool ok = false;
  try {
    ok = cv::imwrite(path, image);
  } catch (const cv::Exception& e) {
    throw InputError(Str("cannot write PNG '", path, "': ", e.what()));
  }
  if (!ok) throw InputError(Str("cannot write PNG '", path, "'"));
}

}  // namespace nsim
