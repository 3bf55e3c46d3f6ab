// Runs the built bdis_eval on a small sequence written to a temp directory:
// scoring disparities computed elsewhere (--predictions, as the demo does with
// the nodelet's output) and its command-line errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/synthetic_scene.hpp"
#include "image_headers.hpp"
#include "tool_runner.hpp"

namespace {

namespace fs = std::filesystem;
using bdis_test::readFile;
using bdis_test::RunResult;

constexpr int kWidth = 64, kHeight = 48;
constexpr float kTrueDisparity = 7.f;

class BdisEvalTest : public bdis_test::ToolTest {
 protected:
  BdisEvalTest() : ToolTest("bdis_eval") {}

  // Three frames with constant ground truth; the images only need to be
  // non-black (the score masks black left pixels).
  void writeSequence() {
    for (const char* sub : {"seq/left", "seq/right", "seq/gt_disparity", "pred"})
      fs::create_directories(path(sub));
    const cv::Mat grey(kHeight, kWidth, CV_8UC1, cv::Scalar(100));
    const cv::Mat gt(kHeight, kWidth, CV_32FC1, cv::Scalar(kTrueDisparity));
    for (const char* name : {"000000.png", "000001.png", "000002.png"}) {
      ASSERT_TRUE(cv::imwrite(path(std::string("seq/left/") + name), grey));
      ASSERT_TRUE(cv::imwrite(path(std::string("seq/right/") + name), grey));
      bdis::writeDisparityPng(path(std::string("seq/gt_disparity/") + name), gt);
    }
  }

  static double jsonNumber(const std::string& json, const std::string& method, const std::string& key) {
    std::smatch m;
    const std::regex re("\"method\": \"" + method + "\"[^}]*?\"" + key + "\": ([0-9.eE+-]+)");
    if (!std::regex_search(json, m, re)) return -1;
    return std::stod(m[1]);
  }
};

TEST_F(BdisEvalTest, ScoresPredictionsAndSkipsFramesWithoutOne) {
  writeSequence();
  // Frame 0: exact except the left quarter, 5 px off (bad2); frame 1 missing
  // (a dropped frame); frame 2: exact with the right half without estimate.
  cv::Mat d0(kHeight, kWidth, CV_32FC1, cv::Scalar(kTrueDisparity));
  d0.colRange(0, kWidth / 4).setTo(kTrueDisparity + 5.f);
  cv::Mat d2(kHeight, kWidth, CV_32FC1, cv::Scalar(kTrueDisparity));
  d2.colRange(kWidth / 2, kWidth).setTo(-1.f);
  bdis::writeDisparityPng(path("pred/000000.png"), d0);
  bdis::writeDisparityPng(path("pred/000002.png"), d2);

  const RunResult r = run({path("seq"), "--predictions", path("pred"), "--json", path("r.json")});
  ASSERT_TRUE(r.exited());
  ASSERT_EQ(r.code(), 0) << r.err;
  EXPECT_NE(r.out.find("2 of 3 frames have predictions"), std::string::npos) << r.out;
  const std::string json = readFile(path("r.json"));
  EXPECT_EQ(jsonNumber(json, "predictions", "frames"), 2);
  // 2 frames x 3072 scorable px; 3072 + 1536 estimated; 768 of them 5 px off.
  EXPECT_NEAR(jsonNumber(json, "predictions", "density"), 0.75, 1e-6);
  EXPECT_NEAR(jsonNumber(json, "predictions", "bad2"), 768.0 / 4608.0, 1e-6);
  EXPECT_NEAR(jsonNumber(json, "predictions", "median_error"), 0.0, 1e-6);
  EXPECT_EQ(json.find("\"dis_fast\""), std::string::npos) << "only predictions unless --methods";

  // With --methods, the others run on the same two frames.
  const RunResult both = run({path("seq"), "--predictions", path("pred"), "--methods",
                              "predictions,dis_fast", "--json", path("b.json")});
  ASSERT_EQ(both.code(), 0) << both.err;
  EXPECT_EQ(jsonNumber(readFile(path("b.json")), "dis_fast", "frames"), 2);
}

// --reference-width W scales the errors by W / width: 3 px off on a 64 px
// wide frame are 1.5 px of a 32 px one, no longer bad2.
TEST_F(BdisEvalTest, ReferenceWidthCountsErrorsInThatFramesPixels) {
  writeSequence();
  cv::Mat d(kHeight, kWidth, CV_32FC1, cv::Scalar(kTrueDisparity));
  d.colRange(0, kWidth / 4).setTo(kTrueDisparity + 3.f);
  for (const char* name : {"000000.png", "000001.png", "000002.png"}) {
    bdis::writeDisparityPng(path(std::string("pred/") + name), d);
  }
  const RunResult own = run({path("seq"), "--predictions", path("pred"), "--json", path("own.json")});
  ASSERT_EQ(own.code(), 0) << own.err;
  EXPECT_NEAR(jsonNumber(readFile(path("own.json")), "predictions", "bad2"), 0.25, 1e-6);
  const RunResult half = run({path("seq"), "--predictions", path("pred"), "--reference-width", "32", "--json",
                              path("half.json")});
  ASSERT_EQ(half.code(), 0) << half.err;
  EXPECT_NEAR(jsonNumber(readFile(path("half.json")), "predictions", "bad2"), 0.0, 1e-6);
  const RunResult twice = run({path("seq"), "--predictions", path("pred"), "--reference-width", "128", "--json",
                               path("twice.json")});
  ASSERT_EQ(twice.code(), 0) << twice.err;
  EXPECT_NEAR(jsonNumber(readFile(path("twice.json")), "predictions", "bad2"), 0.25, 1e-6);
  const RunResult zero = run({path("seq"), "--predictions", path("pred"), "--reference-width", "0"});
  EXPECT_EQ(zero.code(), 2);
  EXPECT_NE(zero.err.find("--reference-width"), std::string::npos) << zero.err;
}

TEST_F(BdisEvalTest, PredictionErrors) {
  writeSequence();
  const RunResult two = run({path("seq"), path("seq"), "--predictions", path("pred")});
  EXPECT_EQ(two.code(), 2);
  EXPECT_NE(two.err.find("--predictions scores one sequence"), std::string::npos) << two.err;

  const RunResult missing = run({path("seq"), "--predictions", path("nowhere")});
  EXPECT_EQ(missing.code(), 1);
  EXPECT_NE(missing.err.find("is not a directory"), std::string::npos) << missing.err;

  const RunResult empty = run({path("seq"), "--predictions", path("pred")});
  EXPECT_EQ(empty.code(), 1);
  EXPECT_NE(empty.err.find("has a file in"), std::string::npos) << empty.err;

  const RunResult no_dir = run({path("seq"), "--methods", "predictions"});
  EXPECT_EQ(no_dir.code(), 2);
  EXPECT_NE(no_dir.err.find("needs --predictions DIR"), std::string::npos) << no_dir.err;
}

TEST_F(BdisEvalTest, RegionsAndConfidenceOfPredictions) {
  writeSequence();
  // Frame 0: the left quarter 5 px off with confidence 0.1, the rest exact
  // with confidence 0.9: the confidence ranks the errors perfectly.
  cv::Mat d(kHeight, kWidth, CV_32FC1, cv::Scalar(kTrueDisparity));
  d.colRange(0, kWidth / 4).setTo(kTrueDisparity + 5.f);
  cv::Mat1w conf(kHeight, kWidth, static_cast<uint16_t>(0.9 * 65535));
  conf.colRange(0, kWidth / 4).setTo(static_cast<uint16_t>(0.1 * 65535));
  bdis::writeDisparityPng(path("pred/000000.png"), d);
  ASSERT_TRUE(cv::imwrite(path("pred/conf_000000.png"), conf));
  const RunResult r = run({path("seq"), "--predictions", path("pred"), "--json", path("r.json")});
  ASSERT_EQ(r.code(), 0) << r.err;
  const std::string json = readFile(path("r.json"));
  // Constant ground truth 7 px: the first 7 columns match outside the right view.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(json, m, std::regex("\"out_of_view\": \\{\"share\": ([0-9.e-]+)")));
  EXPECT_NEAR(std::stod(m[1]), 7.0 / kWidth, 1e-6);
  ASSERT_TRUE(std::regex_search(json, m, std::regex("\"ratio\": ([0-9.e-]+)")));
  EXPECT_NEAR(std::stod(m[1]), 1.0, 1e-6);
  ASSERT_TRUE(std::regex_search(json, m, std::regex("\"bad2_top50\": ([0-9.e-]+)")));
  EXPECT_EQ(std::stod(m[1]), 0.0);
  EXPECT_NE(r.out.find("sparsification"), std::string::npos) << r.out;

  // A frame with a disparity but no confidence, after one with: refused, not
  // ranked as the least confident.
  bdis::writeDisparityPng(path("pred/000001.png"), d);
  const RunResult partial = run({path("seq"), "--predictions", path("pred")});
  EXPECT_EQ(partial.code(), 1);
  EXPECT_NE(partial.err.find("000001.png has no confidence file"), std::string::npos) << partial.err;
}

TEST_F(BdisEvalTest, InstrumentBandsFromLabels) {
  writeSequence();
  // Frame 0 only: exact, with confidence 0.6, except a strip of tissue 1-3 px
  // left of the instrument (columns 27-29, rows 7-32), 5 px too near with 0.9.
  cv::Mat d(kHeight, kWidth, CV_32FC1, cv::Scalar(kTrueDisparity));
  cv::Mat1w conf(kHeight, kWidth, static_cast<uint16_t>(0.6 * 65535));
  d(cv::Rect(27, 7, 3, 26)).setTo(kTrueDisparity + 5.f);
  conf(cv::Rect(27, 7, 3, 26)).setTo(static_cast<uint16_t>(0.9 * 65535));
  bdis::writeDisparityPng(path("pred/000000.png"), d);
  ASSERT_TRUE(cv::imwrite(path("pred/conf_000000.png"), conf));
  const RunResult without = run({path("seq"), "--predictions", path("pred")});
  ASSERT_EQ(without.code(), 0) << without.err;
  EXPECT_EQ(without.out.find("beside the instrument"), std::string::npos) << without.out;

  // The instrument a 20 x 20 square at columns 30-49, rows 10-29: the tissue
  // within 12 px of it is columns 18-61 by rows 0-41 less the square (1448
  // px); a 12 px rim of a 20 px square is all of it (400 px).
  fs::create_directories(path("seq/labels"));
  cv::Mat surfaces(kHeight, kWidth, CV_8UC1, cv::Scalar(1));
  surfaces(cv::Rect(30, 10, 20, 20)).setTo(2);
  for (const char* name : {"000000.png", "000001.png", "000002.png"}) {
    ASSERT_TRUE(cv::imwrite(path(std::string("seq/labels/") + name), surfaces));
  }
  const RunResult r = run({path("seq"), "--predictions", path("pred"), "--json", path("r.json")});
  ASSERT_EQ(r.code(), 0) << r.err;
  EXPECT_NE(r.out.find("beside the instrument"), std::string::npos) << r.out;
  const std::string json = readFile(path("r.json"));
  std::smatch m;
  const std::string number = "([0-9.eE+-]+)";
  ASSERT_TRUE(std::regex_search(json, m, std::regex("\"tissue_within_12px\": \\{\"share\": " + number +
                                                    ", \"density\": " + number + ", \"bad2\": " + number +
                                                    ", \"confident_bad2_share\": " + number +
                                                    ", \"mean_confidence\": " + number)))
      << json;
  EXPECT_NEAR(std::stod(m[1]), 1448.0 / (kWidth * kHeight), 1e-6);
  EXPECT_NEAR(std::stod(m[2]), 1.0, 1e-6);
  EXPECT_NEAR(std::stod(m[3]), 78.0 / 1448, 1e-6);
  EXPECT_NEAR(std::stod(m[4]), 78.0 / 1448, 1e-6);
  EXPECT_NEAR(std::stod(m[5]), (78 * 0.9 + 1370 * 0.6) / 1448, 1e-4);
  ASSERT_TRUE(std::regex_search(json, m, std::regex("\"instrument_rim_12px\": \\{\"share\": " + number +
                                                    ", \"density\": " + number + ", \"bad2\": " + number)))
      << json;
  EXPECT_NEAR(std::stod(m[1]), 400.0 / (kWidth * kHeight), 1e-6);
  EXPECT_EQ(std::stod(m[3]), 0.0);

  // A label image of another size is refused with its name.
  ASSERT_TRUE(cv::imwrite(path("seq/labels/000000.png"), surfaces(cv::Rect(0, 0, 32, 24))));
  const RunResult bad = run({path("seq"), "--predictions", path("pred")});
  EXPECT_EQ(bad.code(), 1);
  EXPECT_NE(bad.err.find("labels/000000.png is not a label image of the left image's size"), std::string::npos)
      << bad.err;
}

TEST_F(BdisEvalTest, DumpedOutputsScoreAsTheRunThatWroteThem) {
  // A dim generated tube: a quarter of its estimates have a confidence below
  // a 16-bit step, so only exact confidence files keep their ranking.
  bdis::synth::SceneConfig cfg = bdis::synth::SceneConfig::variant("dark_tube");
  cfg.width = 320;
  cfg.height = 240;
  cfg.frames = 2;
  bdis::synth::writeSequence(cfg, path("tube"));
  const RunResult dumped = run({path("tube"), "--methods", "bdis", "--dump-dir", path("dump"), "--json", path("a.json")});
  ASSERT_EQ(dumped.code(), 0) << dumped.err;
  ASSERT_TRUE(fs::exists(path("dump/tube/bdis/conf_000001.tiff")));
  const RunResult rescored = run({path("tube"), "--predictions", path("dump/tube/bdis"), "--json", path("b.json")});
  ASSERT_EQ(rescored.code(), 0) << rescored.err;
  auto number = [](const std::string& json, const std::string& key) {
    std::smatch m;
    return std::regex_search(json, m, std::regex("\"" + key + "\": ([0-9.eE+-]+)")) ? std::stod(m[1]) : -1.0;
  };
  const std::string in_run = readFile(path("a.json")), from_files = readFile(path("b.json"));
  const double ratio = number(in_run, "ratio");
  ASSERT_GT(ratio, 1.0) << in_run;
  // The disparity PNG's 1/256 px steps move a few estimates across 2 px; no more.
  EXPECT_NEAR(number(from_files, "ratio"), ratio, 0.02 * ratio) << from_files;
  EXPECT_NEAR(number(from_files, "bad2_top50"), number(in_run, "bad2_top50"), 0.002) << from_files;
  EXPECT_NE(from_files.find("\"monotone\": true"), std::string::npos) << from_files;
}

TEST_F(BdisEvalTest, SequenceWithoutGroundTruthReportsBorderStrips) {
  writeSequence();
  fs::remove_all(path("seq/gt_disparity"));
  const RunResult r = run({path("seq"), "--methods", "dis_fast", "--json", path("r.json")});
  ASSERT_EQ(r.code(), 0) << r.err;
  EXPECT_NE(r.out.find("sequences without ground truth"), std::string::npos) << r.out;
  const std::string json = readFile(path("r.json"));
  EXPECT_NE(json.find("\"ground_truth\": false"), std::string::npos) << json;
  EXPECT_NE(json.find("\"border_outliers\""), std::string::npos) << json;
}

TEST_F(BdisEvalTest, InputsShowWhetherABlockCodecWasThere) {
  // The same weak texture stored as it is and after a JPEG round trip at
  // quality 75: only the second is reported block-coded.
  cv::Mat noise(120, 160, CV_32FC1), texture;
  cv::RNG rng(5);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 3.0);
  cv::normalize(noise, noise, 60, 100, cv::NORM_MINMAX);
  noise.convertTo(texture, CV_8UC1);
  std::vector<uchar> bytes;
  cv::imencode(".jpg", texture, bytes, {cv::IMWRITE_JPEG_QUALITY, 75});
  const cv::Mat coded = cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
  const cv::Mat gt(texture.size(), CV_32FC1, cv::Scalar(kTrueDisparity));
  for (const auto& [name, image] : {std::pair<std::string, cv::Mat>{"raw", texture}, {"coded", coded}}) {
    for (const char* sub : {"/left", "/right", "/gt_disparity"}) fs::create_directories(path(name + sub));
    ASSERT_TRUE(cv::imwrite(path(name + "/left/000000.png"), image));
    ASSERT_TRUE(cv::imwrite(path(name + "/right/000000.png"), image));
    bdis::writeDisparityPng(path(name + "/gt_disparity/000000.png"), gt);
    const RunResult r = run({path(name), "--methods", "dis_fast", "--json", path(name + ".json")});
    ASSERT_EQ(r.code(), 0) << r.err;
    const double contrast = jsonNumber(readFile(path(name + ".json")), "dis_fast", "block_grid_contrast");
    const bool flagged = std::regex_search(r.out, std::regex(name + " +[0-9.]+  block-coded"));
    if (name == "raw") {
      EXPECT_LT(contrast, 1.1);
      EXPECT_FALSE(flagged) << r.out;
    } else {
      EXPECT_GT(contrast, 1.3);
      EXPECT_TRUE(flagged) << r.out;
    }
  }
}

TEST_F(BdisEvalTest, OversizedImagesAreRefusedFromTheirHeaders) {
  writeSequence();
  // A header claiming 20000 x 20000 (the data is 64 x 48): refused unread.
  bdis_test::claimSize(path("seq/right/000001.png"), 20000, 20000);
  RunResult r = run({path("seq"), "--methods", "dis_fast"});
  EXPECT_EQ(r.code(), 1);
  EXPECT_NE(r.err.find(path("seq/right/000001.png") +
                       " is 20000x20000 (400000000 pixels), more than --max-image-pixels 16777216"),
            std::string::npos)
      << r.err;
  // The limit applies to the ground truth and to predictions too, and can be set.
  writeSequence();
  bdis::writeDisparityPng(path("pred/000000.png"), cv::Mat(kHeight, kWidth, CV_32FC1, cv::Scalar(7.f)));
  r = run({path("seq"), "--predictions", path("pred"), "--max-image-pixels", "3072"});
  EXPECT_EQ(r.code(), 0) << r.err;  // 64 x 48 = 3072
  bdis_test::claimSize(path("seq/gt_disparity/000000.png"), 64, 49);
  r = run({path("seq"), "--predictions", path("pred"), "--max-image-pixels", "3072"});
  EXPECT_EQ(r.code(), 1);
  EXPECT_NE(r.err.find(path("seq/gt_disparity/000000.png") + " is 64x49"), std::string::npos) << r.err;
  writeSequence();
  bdis_test::claimSize(path("pred/000000.png"), 64, 49);
  r = run({path("seq"), "--predictions", path("pred"), "--max-image-pixels", "3072"});
  EXPECT_EQ(r.code(), 1);
  EXPECT_NE(r.err.find(path("pred/000000.png") + " is 64x49"), std::string::npos) << r.err;
  r = run({path("seq"), "--max-image-pixels", "0"});
  EXPECT_EQ(r.code(), 2);
  EXPECT_NE(r.err.find("--max-image-pixels needs a whole number >= 1"), std::string::npos) << r.err;
}

TEST_F(BdisEvalTest, BadOptionsFailBeforeTheEvaluation) {
  writeSequence();
  for (const char* frames : {"0", "-1", "2.5", "x"}) {
    const RunResult r = run({path("seq"), "--frames", frames});
    EXPECT_EQ(r.code(), 2) << frames;
    EXPECT_NE(r.err.find("--frames"), std::string::npos) << r.err;
  }
  const RunResult no_methods = run({path("seq"), "--methods", ""});
  EXPECT_EQ(no_methods.code(), 2);
  EXPECT_NE(no_methods.err.find("--methods needs at least one method"), std::string::npos) << no_methods.err;
  const RunResult bad_json = run({path("seq"), "--json", path("missing/dir/r.json")});
  EXPECT_EQ(bad_json.code(), 1);
  EXPECT_NE(bad_json.err.find("does not exist"), std::string::npos) << bad_json.err;
  // Failed at once: no progress bar, nothing scored.
  EXPECT_EQ(bad_json.err.find("3/3"), std::string::npos) << bad_json.err;
}

}  // namespace
