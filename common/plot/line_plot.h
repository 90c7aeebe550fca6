#pragma once
// A small line-plot library on OpenCV drawing: axes with numbered ticks, axis labels, a title,
// a legend and several series; panels can be stacked and saved as PNG. Used by the offline
// prediction evaluation and the closed-loop result plots.

#include <limits>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace nsim {

/// One line of a plot.
struct PlotSeries {
  std::string label;      ///< legend text; empty keeps the series out of the legend
  std::vector<double> x;  ///< abscissae (data units)
  std::vector<double> y;  ///< ordinates (data units), same length; a NaN breaks the line
  /// Line colour (BGR, 0-255); any negative component = the palette colour of the series index.
  cv::Scalar color = cv::Scalar(-1, -1, -1);
  int thickness = 2;  ///< line width (px), in [1, 10]
};

/// Size, text and axis ranges of a plot. NaN limits are taken from the data (y padded by 5 %).
struct PlotConfig {
  int width = 1000;                                         ///< image width (px), >= 240
  int height = 400;                                         ///< image height (px), >= 160
  std::string title;                                        ///< drawn above the axes; may be empty
  std::string x_label;                                      ///< below the x axis, e.g. "time (s)"
  std::string y_label;                                      ///< left of the y axis (rotated)
  double x_min = std::numeric_limits<double>::quiet_NaN();  ///< x axis start (data units)
  double x_max = std::numeric_limits<double>::quiet_NaN();  ///< x axis end
  double y_min = std::numeric_limits<double>::quiet_NaN();  ///< y axis start
  double y_max = std::numeric_limits<double>::quiet_NaN();  ///< y axis end
  bool legend = true;  ///< draw the legend box (top right) when a series has a label
  bool grid = true;    ///< light grid lines at the ticks

  /// Throws InputError naming the first invalid field ("plot.width must be >= 240 px, got 10").
  void Validate() const;
};

/// A line plot: add series, then Render or SavePng.
class LinePlot {
 public:
  /// Validates `config` (InputError).
  explicit LinePlot(PlotConfig config = PlotConfig());

  /// Adds a series. Throws InputError if x and y differ in length or thickness is out of range.
  LinePlot& Add(PlotSeries series);
  /// Adds a series with the palette colour of its index.
  LinePlot& Add(const std::string& label, std::vector<double> x, std::vector<double> y);

  /// Draws the plot: a height x width CV_8UC3 image on a white background.
  cv::Mat Render() const;
  /// Render() written as PNG; throws InputError if the file cannot be written.
  void SavePng(const std::string& path) const;

  /// Pixel rectangle of the axes area (inside the margins).
  cv::Rect plot_area() const;
  /// Pixel position of the data point (x, y) with the current axis ranges (sub-pixel).
  cv::Point2d ToPixel(double x, double y) const;
  /// Axis ranges in use: {x_min, x_max, y_min, y_max} after applying the config and the data.
  cv::Vec4d Ranges() const;

  const std::vector<PlotSeries>& series() const { return series_; }
  const PlotConfig& config() const { return config_; }

 private:
  PlotConfig config_;
  std::vector<PlotSeries> series_;
};

/// The i-th colour of the default palette (BGR); cycles after 8.
cv::Scalar PaletteColor(int i);

/// Tick positions at "nice" steps (1, 2 or 5 times a power of ten) inside [lo, hi], at most
/// about max_ticks of them. Precondition: lo < hi finite, max_ticks >= 2.
std::vector<double> NiceTicks(double lo, double hi, int max_ticks);

/// Stacks images of equal width and type top to bottom (e.g. rendered panels).
/// Throws InputError if the list is empty or widths or types differ.
cv::Mat StackVertically(const std::vector<cv::Mat>& panels);

/// Writes an image as PNG; throws InputError naming the path if it fails.
void WritePng(const std::string& path, const cv::Mat& image);

}  // namespace nsim
