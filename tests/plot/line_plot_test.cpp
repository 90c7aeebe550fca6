#include "common/plot/line_plot.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/core/error.h"

namespace nsim {
namespace {

namespace fs = std::filesystem;

// BGR pixel at a sub-pixel position, rounded
cv::Vec3b PixelAt(const cv::Mat& img, const cv::Point2d& p) {
  return img.at<cv::Vec3b>(static_cast<int>(std::lround(p.y)), static_cast<int>(std::lround(p.x)));
}

bool IsRed(const cv::Vec3b& c) { return c[2] > 180 && c[1] < 90 && c[0] < 90; }

TEST(LinePlot, WritesAPngOfTheConfiguredSizeWithTheSeriesWhereItBelongs) {
  PlotConfig config;
  config.width = 640;
  config.height = 360;
  config.title = "test";
  config.x_label = "time (s)";
  config.y_label = "value (mm)";
  config.y_min = 0;
  config.y_max = 1;
  LinePlot plot(config);
  PlotSeries line{"half", {0.0, 1.0}, {0.5, 0.5}, cv::Scalar(0, 0, 255), 3};
  PlotSeries gap{
      "gap", {0.0, 0.2, 0.4, 0.6, 0.8}, {0.2, 0.2, NAN, 0.2, 0.2}, cv::Scalar(0, 0, 255), 3};
  plot.Add(line).Add(gap);

  const fs::path path = fs::temp_directory_path() / "nsim_line_plot_test.png";
  fs::remove(path);
  plot.SavePng(path.string());
  const cv::Mat img = cv::imread(path.string());
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 640);
  EXPECT_EQ(img.rows, 360);

  // on the series: red; half-way between the two series: not red
  EXPECT_TRUE(IsRed(PixelAt(img, plot.ToPixel(0.5, 0.5))));
  EXPECT_TRUE(IsRed(PixelAt(img, plot.ToPixel(0.1, 0.2))));
  EXPECT_FALSE(IsRed(PixelAt(img, plot.ToPixel(0.5, 0.35))));
  // the NaN breaks the gap series between x = 0.2 and 0.6
  EXPECT_FALSE(IsRed(PixelAt(img, plot.ToPixel(0.4, 0.2))));
  // the axes area has a frame, the margins have text (dark pixels left of the axes)
  const cv::Rect area = plot.plot_area();
  EXPECT_LT(img.at<cv::Vec3b>(area.y + area.height / 2, area.x)[0], 100);
  cv::Mat left_margin;
  cv::cvtColor(img(cv::Rect(0, area.y, area.x - 6, area.height)), left_margin, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(left_margin < 128), 20);
}

TEST(LinePlot, RangesComeFromTheDataWhenNotFixed) {
  LinePlot plot;
  plot.Add("a", {1.0, 3.0}, {-2.0, 8.0});
  const cv::Vec4d r = plot.Ranges();
  EXPECT_DOUBLE_EQ(r[0], 1.0);
  EXPECT_DOUBLE_EQ(r[1], 3.0);
  EXPECT_DOUBLE_EQ(r[2], -2.5);  // 5 % padding
  EXPECT_DOUBLE_EQ(r[3], 8.5);
  // palette colour assigned
  EXPECT_EQ(plot.series()[0].color, PaletteColor(0));
  const cv::Mat img = plot.Render();
  EXPECT_EQ(img.type(), CV_8UC3);
  EXPECT_EQ(img.rows, 400);
}

TEST(NiceTicks, AreRoundAndInsideTheRange) {
  const std::vector<double> t = NiceTicks(0, 1, 5);
  ASSERT_EQ(t.size(), 6u);
  EXPECT_NEAR(t[1], 0.2, 1e-15);
  for (double v : NiceTicks(-3.7, 12.2, 8)) {
    EXPECT_GE(v, -3.7);
    EXPECT_LE(v, 12.2);
    EXPECT_NEAR(std::remainder(v, 2.0), 0.0, 1e-12);
  }
}

TEST(LinePlot, BadInputThrowsInputError) {
  PlotConfig config;
  config.width = 10;
  try {
    LinePlot{config};
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "plot.width must be >= 240 px, got 10");
  }
  LinePlot plot;
  EXPECT_THROW(plot.Add("bad", {1.0, 2.0}, {1.0}), InputError);
  EXPECT_THROW(WritePng("/nonexistent_dir_nsim/x.png", plot.Render()), InputError);
  EXPECT_THROW(StackVertically({}), InputError);
  EXPECT_EQ(StackVertically({plot.Render(), plot.Render()}).rows, 800);
}

}  // namespace
}  // namespace nsim
