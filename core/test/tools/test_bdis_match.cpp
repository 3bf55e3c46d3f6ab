// Runs the built bdis_match executable on synthetic pairs written to a temp
// directory and checks its outputs, messages and exit codes.
#include <gtest/gtest.h>

#include <spawn.h>
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bdis_stereo/evaluation.hpp"
#include "test_images.hpp"
#include "image_headers.hpp"
#include "tool_runner.hpp"

namespace {

namespace fs = std::filesystem;

constexpr int kShift = 6;  // px, the known disparity of the synthetic pair
constexpr int kWidth = 160, kHeight = 128;

using bdis_test::readFile;
using bdis_test::RunResult;

class BdisMatchTest : public bdis_test::ToolTest {
 protected:
  BdisMatchTest() : ToolTest("bdis_match") {}

  // A smooth random texture (no pure black) and the pair with disparity kShift.
  static void makePair(int seed, cv::Mat& left, cv::Mat& right, int width = kWidth,
                       int height = kHeight) {
    bdis_test::blurredNoisePair(static_cast<uint64_t>(seed) + 1, kShift, width, height, 1.5, left, right);
  }

  void writePair(const std::string& left_path, const std::string& right_path, int seed = 0) {
    cv::Mat l, r;
    makePair(seed, l, r);
    ASSERT_TRUE(cv::imwrite(left_path, l));
    ASSERT_TRUE(cv::imwrite(right_path, r));
  }

  // Exits normally (no signal), non-zero, and mentions `needle`.
  void expectFailure(const RunResult& r, const std::string& needle) {
    ASSERT_TRUE(r.exited()) << "terminated by a signal, status " << r.status;
    EXPECT_NE(r.code(), 0);
    EXPECT_NE(r.err.find(needle), std::string::npos)
        << "stderr lacks '" << needle << "':\n" << r.err;
  }
};

double interiorMedian(const cv::Mat& disparity) {
  std::vector<float> v;
  const int m = 16;
  for (int y = m; y < disparity.rows - m; ++y) {
    for (int x = m + kShift; x < disparity.cols - m; ++x) {
      const float d = disparity.at<float>(y, x);
      if (d >= 0.f) v.push_back(d);
    }
  }
  if (v.empty()) return -1;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

TEST_F(BdisMatchTest, Help) {
  const RunResult r = run({"--help"});
  ASSERT_TRUE(r.exited());
  EXPECT_EQ(r.code(), 0);
  EXPECT_NE(r.out.find("usage: bdis_match"), std::string::npos);
  EXPECT_NE(r.out.find("65535"), std::string::npos);  // confidence encoding documented
  EXPECT_NE(r.out.find("--variance"), std::string::npos);
}

TEST_F(BdisMatchTest, SinglePairKnownDisparity) {
  writePair(path("l.png"), path("r.png"));
  const RunResult r = run({path("l.png"), path("r.png"), path("d.png")});
  ASSERT_TRUE(r.exited());
  ASSERT_EQ(r.code(), 0) << r.err;

  const cv::Mat raw = cv::imread(path("d.png"), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(raw.empty());
  EXPECT_EQ(raw.type(), CV_16UC1);
  EXPECT_EQ(raw.size(), cv::Size(kWidth, kHeight));
  const double med = interiorMedian(bdis::readDisparityPng(path("d.png")));
  EXPECT_NEAR(med, kShift, 0.25);

  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex(R"(time_ms=([0-9.eE+-]+))"))) << r.out;
  EXPECT_GT(std::stod(m[1]), 0.0);
}

TEST_F(BdisMatchTest, ColourAndAlphaInputs) {
  cv::Mat l, r, lc, rc;
  makePair(3, l, r);
  cv::cvtColor(l, lc, cv::COLOR_GRAY2BGRA);
  cv::cvtColor(r, rc, cv::COLOR_GRAY2BGRA);
  ASSERT_TRUE(cv::imwrite(path("l.png"), lc));
  ASSERT_TRUE(cv::imwrite(path("r.png"), rc));
  const RunResult res = run({path("l.png"), path("r.png"), path("d.png")});
  ASSERT_TRUE(res.exited());
  ASSERT_EQ(res.code(), 0) << res.err;
  EXPECT_NEAR(interiorMedian(bdis::readDisparityPng(path("d.png"))), kShift, 0.25);
}

TEST_F(BdisMatchTest, ConfidenceAndVariance) {
  writePair(path("l.png"), path("r.png"));
  const RunResult r = run({path("l.png"), path("r.png"), path("d.png"), "--preset", "fast",
                           "--confidence", path("c.png"), "--variance", path("v.png")});
  ASSERT_TRUE(r.exited());
  ASSERT_EQ(r.code(), 0) << r.err;
  const cv::Mat d = cv::imread(path("d.png"), cv::IMREAD_UNCHANGED);
  const cv::Mat c = cv::imread(path("c.png"), cv::IMREAD_UNCHANGED);
  const cv::Mat v = cv::imread(path("v.png"), cv::IMREAD_UNCHANGED);
  for (const cv::Mat* m : {&d, &c, &v}) {
    ASSERT_FALSE(m->empty());
    EXPECT_EQ(m->type(), CV_16UC1);
    EXPECT_EQ(m->size(), cv::Size(kWidth, kHeight));
  }
  // Both maps are 0 exactly where there is no estimate (and confidence / variance > 0 elsewhere).
  int mismatches = 0;
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      const bool est = d.at<uint16_t>(y, x) > 0;
      mismatches += (v.at<uint16_t>(y, x) > 0) != est;
      mismatches += est && c.at<uint16_t>(y, x) == 0;
      mismatches += !est && c.at<uint16_t>(y, x) != 0;
    }
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(cv::countNonZero(d), d.total() / 2);
}

TEST_F(BdisMatchTest, DirectoryMode) {
  const std::string L = path("left"), R = path("right"), O = path("out/disp"), C = path("conf");
  fs::create_directories(L);
  fs::create_directories(R);
  for (int i = 0; i < 3; ++i) {
    const std::string name = "00000" + std::to_string(i) + ".png";
    writePair(L + "/" + name, R + "/" + name, i);
  }
  writePair(L + "/only_left.png", path("unused.png"), 9);  // not in both: ignored
  const RunResult r = run({"--left-dir", L, "--right-dir", R, "--out-dir", O, "--preset", "fast",
                           "--confidence-dir", C});
  ASSERT_TRUE(r.exited());
  ASSERT_EQ(r.code(), 0) << r.err;
  size_t written = 0;
  for (const auto& e : fs::directory_iterator(O)) {
    ++written;
    EXPECT_NEAR(interiorMedian(bdis::readDisparityPng(e.path().string())), kShift, 0.25)
        << e.path();
  }
  EXPECT_EQ(written, 3u);
  EXPECT_TRUE(fs::exists(C + "/000002.png"));
  EXPECT_FALSE(fs::exists(O + "/only_left.png"));
  std::smatch m;
  ASSERT_TRUE(std::regex_search(
      r.out, m,
      std::regex(R"(frames=3 failed=0 median_ms=([0-9.]+) mean_density=([0-9.]+) out_dir=(\S+))")))
      << r.out;
  EXPECT_GT(std::stod(m[1]), 0.0);
  EXPECT_GT(std::stod(m[2]), 0.5);
  EXPECT_LE(std::stod(m[2]), 1.0);
  EXPECT_EQ(m[3].str(), O);
}

TEST_F(BdisMatchTest, ConfidenceAsFloatTiff) {
  // The exact confidence: a float TIFF, 0 exactly where the disparity has no
  // estimate, in both modes; the PNG of the same run within its 16-bit step.
  writePair(path("l.png"), path("r.png"));
  const RunResult single = run({path("l.png"), path("r.png"), path("d.png"), "--confidence", path("c.tiff")});
  ASSERT_EQ(single.code(), 0) << single.err;
  const cv::Mat d = bdis::readDisparityPng(path("d.png"));
  const cv::Mat c = cv::imread(path("c.tiff"), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(c.type(), CV_32FC1);
  ASSERT_EQ(c.size(), d.size());
  int mismatches = 0;
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      const float v = c.at<float>(y, x);
      mismatches += d.at<float>(y, x) >= 0.f ? !(v > 0.f && v <= 1.f) : v != 0.f;
    }
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(cv::countNonZero(c), static_cast<int>(c.total() / 2));

  const std::string L = path("left"), R = path("right");
  fs::create_directories(L);
  fs::create_directories(R);
  writePair(L + "/000000.png", R + "/000000.png");
  const RunResult dir = run({"--left-dir", L, "--right-dir", R, "--out-dir", path("out"), "--confidence-dir",
                             path("conf"), "--confidence-format", "tiff"});
  ASSERT_EQ(dir.code(), 0) << dir.err;
  const cv::Mat from_dir = cv::imread(path("conf/000000.tiff"), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(from_dir.type(), CV_32FC1);
  EXPECT_EQ(cv::norm(from_dir, c, cv::NORM_INF), 0.0);  // the same pair, the same confidence
  ASSERT_EQ(run({path("l.png"), path("r.png"), path("d2.png"), "--confidence", path("c.png")}).code(), 0);
  cv::Mat png;
  cv::imread(path("c.png"), cv::IMREAD_UNCHANGED).convertTo(png, CV_32FC1, 1.0 / 65535);
  EXPECT_LE(cv::norm(png, c, cv::NORM_INF), 1.0 / 65535 + 1e-7);  // rounded, estimates at least 1

  expectFailure(run({"--left-dir", L, "--right-dir", R, "--out-dir", path("out"), "--confidence-dir", path("conf"),
                     "--confidence-format", "exr"}),
                "png or tiff");
  expectFailure(run({"--left-dir", L, "--right-dir", R, "--out-dir", path("out"), "--confidence-format", "tiff"}),
                "needs --confidence-dir");
  expectFailure(run({path("l.png"), path("r.png"), path("d.png"), "--confidence-format", "tiff"}), "C.tiff");
  expectFailure(run({path("l.png"), path("r.png"), path("d.png"), "--confidence", path("c.jpg")}), ".png (16-bit) or .tiff");
}

TEST_F(BdisMatchTest, DirectoryModeSkipsFailedFrame) {
  const std::string L = path("left"), R = path("right"), O = path("out");
  fs::create_directories(L);
  fs::create_directories(R);
  writePair(L + "/a.png", R + "/a.png", 1);
  writePair(L + "/c.png", R + "/c.png", 2);
  cv::Mat l, r;
  makePair(4, l, r);
  ASSERT_TRUE(cv::imwrite(L + "/b.png", l));
  ASSERT_TRUE(cv::imwrite(R + "/b.png", r(cv::Rect(0, 0, kWidth - 8, kHeight))));
  const RunResult res = run({"--left-dir", L, "--right-dir", R, "--out-dir", O, "--preset", "fast"});
  expectFailure(res, "b.png");
  EXPECT_EQ(res.code(), 1);
  EXPECT_NE(res.out.find("frames=2 failed=1"), std::string::npos) << res.out;
  EXPECT_TRUE(fs::exists(O + "/a.png"));
  EXPECT_TRUE(fs::exists(O + "/c.png"));
  EXPECT_FALSE(fs::exists(O + "/b.png"));
}

// Every kind of frame a replay can hold, in one directory: the bad ones fail
// with their reason, the degenerate ones succeed with no estimate, and the good
// frames after them come out right.
TEST_F(BdisMatchTest, DirectoryModeBadAndDegenerateFrames) {
  const std::string L = path("left"), R = path("right"), O = path("out");
  fs::create_directories(L);
  fs::create_directories(R);
  cv::Mat l, r;
  makePair(1, l, r);
  auto write = [&](const std::string& name, const cv::Mat& left, const cv::Mat& right) {
    ASSERT_TRUE(cv::imwrite(L + "/" + name, left)) << name;
    ASSERT_TRUE(cv::imwrite(R + "/" + name, right)) << name;
  };
  const cv::Mat row(1, kWidth, CV_8UC1, cv::Scalar(100)), column(kHeight, 1, CV_8UC1, cv::Scalar(100));
  cv::Mat lf, rf;
  l.convertTo(lf, CV_32FC1);
  r.convertTo(rf, CV_32FC1);
  write("a_row.png", row, row);
  write("b_column.png", column, column);
  write("c_float.tiff", lf, rf);
  write("d_black.png", cv::Mat::zeros(kHeight, kWidth, CV_8UC1), cv::Mat::zeros(kHeight, kWidth, CV_8UC1));
  write("e_saturated.png", cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(255)),
        cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(255)));
  write("f_good.png", l, r);
  const RunResult res = run({"--left-dir", L, "--right-dir", R, "--out-dir", O});
  expectFailure(res, "a_row.png failed");
  EXPECT_EQ(res.code(), 1);
  for (const char* needle : {"160x1", "1x128", "at least 32", "c_float.tiff failed", "32FC1", "8-bit"}) {
    EXPECT_NE(res.err.find(needle), std::string::npos) << "stderr lacks '" << needle << "':\n" << res.err;
  }
  EXPECT_NE(res.out.find("frames=3 failed=3"), std::string::npos) << res.out;
  for (const char* name : {"a_row.png", "b_column.png", "c_float.png"}) EXPECT_FALSE(fs::exists(O + "/" + name));
  for (const char* name : {"d_black.png", "e_saturated.png"}) {
    const cv::Mat d = bdis::readDisparityPng(O + "/" + name);
    ASSERT_EQ(d.size(), cv::Size(kWidth, kHeight)) << name;
    EXPECT_EQ(cv::countNonZero(d >= 0.f), 0) << name << ": a flat frame got disparities";
  }
  EXPECT_NEAR(interiorMedian(bdis::readDisparityPng(O + "/f_good.png")), kShift, 0.25);
}

TEST_F(BdisMatchTest, MissingFile) {
  writePair(path("l.png"), path("r.png"));
  expectFailure(run({path("l.png"), path("nope.png"), path("d.png")}), "nope.png");
  expectFailure(run({path("l.png"), path("nope.png"), path("d.png")}), "no such file");
  EXPECT_FALSE(fs::exists(path("d.png")));
}

TEST_F(BdisMatchTest, UnreadableImage) {
  writePair(path("l.png"), path("r.png"));
  std::ofstream(path("junk.png")) << "not an image";
  expectFailure(run({path("junk.png"), path("r.png"), path("d.png")}), "not a readable image");
}

TEST_F(BdisMatchTest, MismatchedSizes) {
  cv::Mat l, r;
  makePair(0, l, r);
  ASSERT_TRUE(cv::imwrite(path("l.png"), l));
  ASSERT_TRUE(cv::imwrite(path("r.png"), r(cv::Rect(0, 0, kWidth - 10, kHeight))));
  const RunResult res = run({path("l.png"), path("r.png"), path("d.png")});
  expectFailure(res, "equal sizes");
  EXPECT_NE(res.err.find(path("l.png")), std::string::npos) << res.err;  // prefixed with names
}

TEST_F(BdisMatchTest, SixteenBitInput) {
  cv::Mat l, r, l16, r16;
  makePair(0, l, r);
  l.convertTo(l16, CV_16UC1, 256);
  r.convertTo(r16, CV_16UC1, 256);
  ASSERT_TRUE(cv::imwrite(path("l.png"), l16));
  ASSERT_TRUE(cv::imwrite(path("r.png"), r16));
  const RunResult res = run({path("l.png"), path("r.png"), path("d.png")});
  expectFailure(res, "8-bit");
  EXPECT_NE(res.err.find(path("l.png")), std::string::npos) << res.err;
}

TEST_F(BdisMatchTest, UnknownPreset) {
  writePair(path("l.png"), path("r.png"));
  expectFailure(run({path("l.png"), path("r.png"), path("d.png"), "--preset", "turbo"}), "turbo");
}

TEST_F(BdisMatchTest, SetTakesTypedValues) {
  writePair(path("l.png"), path("r.png"));
  // A whole real for an int field, a YAML boolean word, an integer for a float field.
  const RunResult r = run({path("l.png"), path("r.png"), path("d.png"), "--set", "iterations=3.0", "--set",
                           "propagation=yes", "--set", "sigma_r=1", "--set", "mean_normalization=true"});
  ASSERT_TRUE(r.exited());
  ASSERT_EQ(r.code(), 0) << r.err;
  EXPECT_NEAR(interiorMedian(bdis::readDisparityPng(path("d.png"))), kShift, 0.25);
}

TEST_F(BdisMatchTest, BadSet) {
  writePair(path("l.png"), path("r.png"));
  const std::string l = path("l.png"), r = path("r.png"), d = path("d.png");
  expectFailure(run({l, r, d, "--set", "no_such_param=1"}), "no_such_param");
  expectFailure(run({l, r, d, "--set", "iterations=abc"}), "iterations");
  expectFailure(run({l, r, d, "--set", "iterations=nan"}),
                "--set: parameter iterations = nan is not a finite number");
  // The same rules as parameter files and the ROS node: no silent rounding, no numbers for booleans.
  expectFailure(run({l, r, d, "--set", "iterations=2.5"}),
                "--set: parameter iterations = 2.5 must be a whole number");
  expectFailure(run({l, r, d, "--set", "compute_variance=1"}), "compute_variance = 1 must be true or false");
  expectFailure(run({l, r, d, "--set", "patch_size=33"}),
                "patch_size = 33 is out of range [4, 32]: patch side");
  EXPECT_FALSE(fs::exists(d));
  expectFailure(run({l, r, d, "--set", "iterations"}), "NAME=VALUE");
  expectFailure(run({l, r, d, "--set"}), "--set needs a value");
}

TEST_F(BdisMatchTest, BadParamsFile) {
  writePair(path("l.png"), path("r.png"));
  const std::string l = path("l.png"), r = path("r.png"), d = path("d.png");
  std::ofstream(path("bad.yaml")) << "%YAML:1.0\nno_such_param: 3\n";
  expectFailure(run({l, r, d, "--params", path("bad.yaml")}), "no_such_param");
  expectFailure(run({l, r, d, "--params", path("missing.yaml")}), "missing.yaml");
  std::ofstream(path("garbage.yaml")) << "{{{ : : not yaml\n";
  const RunResult g = run({l, r, d, "--params", path("garbage.yaml")});
  expectFailure(g, "garbage.yaml");
  EXPECT_EQ(std::count(g.err.begin(), g.err.end(), '\n'), 1) << g.err;  // one line
  std::ofstream(path("empty.yaml")) << "";
  expectFailure(run({l, r, d, "--params", path("empty.yaml")}), path("empty.yaml") + " is empty");
  std::ofstream(path("nan.yaml")) << "iterations: .nan\n";
  expectFailure(run({l, r, d, "--params", path("nan.yaml")}), "iterations = nan is not a finite number");
  std::ofstream(path("fraction.yaml")) << "iterations: 2.5\n";
  expectFailure(run({l, r, d, "--params", path("fraction.yaml")}), "iterations = 2.5 must be a whole number");
  EXPECT_FALSE(fs::exists(d));
}

TEST_F(BdisMatchTest, UnwritableOutput) {
  writePair(path("l.png"), path("r.png"));
  const std::string l = path("l.png"), r = path("r.png");
  expectFailure(run({l, r, path("no_dir/d.png")}), "does not exist");
  // A regular file where a directory is expected (fails even for root).
  expectFailure(run({l, r, path("l.png/d.png")}), "not a directory");
  expectFailure(run({l, r, path("d.png"), "--confidence", path("no_dir/c.png")}), "no_dir");
  expectFailure(run({l, r, path("d.jpg")}), ".png");
  const auto before = fs::last_write_time(l);
  expectFailure(run({l, r, l}), "same path");  // would overwrite an input
  EXPECT_EQ(fs::last_write_time(l), before);
  fs::create_directories(path("left"));
  fs::create_directories(path("right"));
  writePair(path("left/a.png"), path("right/a.png"));
  expectFailure(run({"--left-dir", path("left"), "--right-dir", path("right"), "--out-dir",
                     path("l.png/out")}),
                "cannot create output directory");
}

// An image above --max-image-pixels (default 4096 x 4096, as the nodelet) is
// refused from its header: the files below claim 20000 x 20000 in a header
// patched into a small image, so only a header probe gives this message (a
// decoder would fail on the data, or first allocate 400 megapixels).
TEST_F(BdisMatchTest, OversizedImageIsRefusedFromItsHeader) {
  writePair(path("l.png"), path("r.png"));
  const cv::Mat small(48, 64, CV_8UC1, cv::Scalar(100));
  for (const std::string ext : {".png", ".jpg", ".bmp", ".pgm"}) {
    const std::string big = path("big" + ext);
    ASSERT_TRUE(cv::imwrite(big, small));
    bdis_test::claimSize(big, 20000, 20000);
    const auto t0 = std::chrono::steady_clock::now();
    const RunResult r = run({big, path("r.png"), path("d.png")});
    expectFailure(r, big + " is 20000x20000 (400000000 pixels), more than --max-image-pixels 16777216 "
                      "(4096x4096): downscale the images or raise --max-image-pixels");
    EXPECT_EQ(r.code(), 1);
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5)) << ext;
    // The right image is probed before the left one is decoded, too.
    expectFailure(run({path("l.png"), big, path("d.png")}), big + " is 20000x20000");
  }
  EXPECT_FALSE(fs::exists(path("d.png")));
  // A valid image just above the default: 4100 x 4100 = 16810000 pixels.
  ASSERT_TRUE(cv::imwrite(path("valid_big.png"), cv::Mat(4100, 4100, CV_8UC1, cv::Scalar(7))));
  expectFailure(run({path("valid_big.png"), path("valid_big.png"), path("d.png")}),
                "is 4100x4100 (16810000 pixels), more than --max-image-pixels 16777216");
  // Directory mode: the frame is reported and skipped.
  fs::create_directories(path("left"));
  fs::create_directories(path("right"));
  fs::copy_file(path("big.png"), path("left/a.png"));
  fs::copy_file(path("r.png"), path("right/a.png"));
  expectFailure(run({"--left-dir", path("left"), "--right-dir", path("right"), "--out-dir", path("out")}),
                "frame a.png failed: " + path("left/a.png") + " is 20000x20000");
}

TEST_F(BdisMatchTest, MaxImagePixelsOption) {
  writePair(path("l.png"), path("r.png"));  // 160 x 128 = 20480 pixels
  const std::string l = path("l.png"), r = path("r.png"), d = path("d.png");
  expectFailure(run({l, r, d, "--max-image-pixels", "20479"}),
                l + " is 160x128 (20480 pixels), more than --max-image-pixels 20479");
  EXPECT_FALSE(fs::exists(d));
  const RunResult ok = run({l, r, d, "--max-image-pixels", "20480"});
  ASSERT_EQ(ok.code(), 0) << ok.err;
  EXPECT_TRUE(fs::exists(d));
  for (const char* bad : {"0", "-5", "1e9", "x"}) {
    const RunResult res = run({l, r, d, "--max-image-pixels", bad});
    expectFailure(res, "--max-image-pixels needs");
    EXPECT_EQ(res.code(), 2) << bad;
  }
  EXPECT_NE(run({"--help"}).out.find("--max-image-pixels N"), std::string::npos);
}

TEST_F(BdisMatchTest, BadCommandLine) {
  const RunResult none = run({});
  expectFailure(none, "expected LEFT RIGHT OUT.png");
  EXPECT_EQ(none.code(), 2);
  expectFailure(run({"a.png", "b.png", "c.png", "--bogus"}), "unknown option --bogus");
  expectFailure(run({"--left-dir", "x", "--out-dir", "y"}), "--right-dir");
}

}  // namespace
