// The nodelet's units that need no master: the statistics and the watchdog's
// text, the frame mailbox, and the dynamic_reconfigure binding.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <thread>

#include <diagnostic_updater/DiagnosticStatusWrapper.h>

#include "../../src/frame_mailbox.hpp"
#include "../../src/matcher_reconfigure.hpp"
#include "../../src/node_statistics.hpp"

namespace {

using bdis_stereo::InputStatus;
using bdis_stereo::noPairWarning;

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

std::string valueOf(const diagnostic_updater::DiagnosticStatusWrapper& stat, const std::string& key) {
  for (const auto& kv : stat.values) {
    if (kv.key == key) return kv.value;
  }
  ADD_FAILURE() << "no key " << key;
  return "";
}

InputStatus quietInputs(uint64_t l, uint64_t r, uint64_t li, uint64_t ri) {
  InputStatus s;
  s.subscribed = true;
  s.seconds_since_pair = 4.5;
  s.since_pair.left_images = l;
  s.since_pair.right_images = r;
  s.since_pair.left_infos = li;
  s.since_pair.right_infos = ri;
  s.topics = {"/s/left/image_rect", "/s/right/image_rect", "/s/left/camera_info", "/s/right/camera_info"};
  return s;
}

TEST(NoPairWarning, NamesTheTopicsAndTheLikelyCause) {
  const std::string silent = noPairWarning(quietInputs(5, 0, 5, 5), false, 3.0);
  EXPECT_TRUE(contains(silent,
                       "no synchronised stereo pair for 4 s, although 5 left images (/s/left/image_rect), "
                       "0 right images (/s/right/image_rect)"))
      << silent;
  EXPECT_TRUE(contains(silent, "Likely causes: the right image (/s/right/image_rect) is silent")) << silent;
  EXPECT_FALSE(contains(silent, "left image (/s/left/image_rect) is silent")) << silent;
  EXPECT_FALSE(contains(silent, "camera_info missing")) << silent;
  const std::string no_info = noPairWarning(quietInputs(5, 5, 0, 5), false, 3.0);
  EXPECT_TRUE(contains(no_info, "the left camera_info (/s/left/camera_info) is silent: camera_info missing"))
      << no_info;
  EXPECT_FALSE(contains(no_info, "right camera_info (/s/right/camera_info) is silent")) << no_info;
  EXPECT_TRUE(contains(noPairWarning(quietInputs(5, 5, 5, 5), false, 3.0), "try approximate_sync:=true"));
  EXPECT_TRUE(contains(noPairWarning(quietInputs(5, 5, 5, 5), true, 3.0), "even for approximate_sync"));
}

TEST(NoPairWarning, QuietWhenThereIsNothingToSay) {
  EXPECT_EQ(noPairWarning(quietInputs(5, 5, 5, 5), false, 5.0), "");  // not long enough
  EXPECT_EQ(noPairWarning(quietInputs(2, 2, 2, 2), false, 3.0), "");  // a bag's last stragglers
  InputStatus idle = quietInputs(5, 5, 5, 5);
  idle.subscribed = false;
  EXPECT_EQ(noPairWarning(idle, false, 3.0), "");
}

TEST(NodeStatistics, CountsAndDiagnoses) {
  bdis_stereo::NodeStatistics stats;
  for (int i = 0; i < 4; ++i) stats.frameIn();
  stats.droppedBusy();
  stats.frameOut(10.0, 20.0);
  stats.frameOut(30.0, 40.0);
  const bdis_stereo::FrameCounters t = stats.totals();
  EXPECT_EQ(t.frames_in, 4u);
  EXPECT_EQ(t.frames_out, 2u);
  EXPECT_EQ(t.dropped_busy, 1u);
  InputStatus input = quietInputs(0, 0, 0, 0);
  input.total.left_images = 7;
  input.total.time_jumps = 2;
  diagnostic_updater::DiagnosticStatusWrapper stat;
  stats.diagnose(stat, input, "fast", 3.0);
  EXPECT_EQ(stat.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_EQ(stat.message, "dropping frames: processing slower than input");
  EXPECT_EQ(valueOf(stat, "frames_in"), "4");
  EXPECT_EQ(valueOf(stat, "processing_ms_mean"), "20.00");
  EXPECT_EQ(valueOf(stat, "processing_ms_max"), "30.00");
  EXPECT_EQ(valueOf(stat, "latency_ms_max"), "40.00");
  EXPECT_EQ(valueOf(stat, "left_images"), "7");
  EXPECT_EQ(valueOf(stat, "time_jumps"), "2");
  EXPECT_EQ(valueOf(stat, "preset"), "fast");
  // The next window starts afresh.
  diagnostic_updater::DiagnosticStatusWrapper next;
  stats.diagnose(next, input, "fast", 3.0);
  EXPECT_EQ(next.message, "ok");
  EXPECT_EQ(valueOf(next, "processing_ms_mean"), "0.00");
  EXPECT_EQ(valueOf(next, "frames_in"), "4");  // cumulative
  EXPECT_EQ(valueOf(next, "input_block_grid"), "1.00");  // not checked yet: no grid
}

TEST(NodeStatistics, BlockCodedInputWarnsWhileNothingWorseIsWrong) {
  bdis_stereo::NodeStatistics stats;
  stats.frameIn();
  stats.frameOut(10.0, 20.0);
  stats.inputBlockGrid(bdis::BlockArtefactCheck{2.37});
  diagnostic_updater::DiagnosticStatusWrapper coded;
  stats.diagnose(coded, quietInputs(0, 0, 0, 0), "balanced", 3.0);
  EXPECT_EQ(coded.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_TRUE(contains(coded.message, "input block-coded (JPEG-like)")) << coded.message;
  EXPECT_EQ(valueOf(coded, "input_block_grid"), "2.37");
  stats.rejected("left image is empty");  // bad input outranks it
  diagnostic_updater::DiagnosticStatusWrapper bad;
  stats.diagnose(bad, quietInputs(0, 0, 0, 0), "balanced", 3.0);
  EXPECT_EQ(bad.level, diagnostic_msgs::DiagnosticStatus::ERROR);
  stats.inputBlockGrid(bdis::BlockArtefactCheck{1.02});
  diagnostic_updater::DiagnosticStatusWrapper clean;
  stats.diagnose(clean, quietInputs(0, 0, 0, 0), "balanced", 3.0);
  EXPECT_EQ(clean.message, "ok");
}

TEST(NodeStatistics, RejectionsAreCountedAlwaysAndLoggedThrottledPerMessage) {
  bdis_stereo::NodeStatistics stats;
  EXPECT_TRUE(stats.rejected("left image is empty"));
  EXPECT_FALSE(stats.rejected("left image is empty"));         // the same again: not yet
  EXPECT_TRUE(stats.rejected("right camera_info P[3] is 0"));  // another one: at once
  EXPECT_EQ(stats.totals().rejected, 3u);
  stats.error("OpenCV: boom");
  diagnostic_updater::DiagnosticStatusWrapper stat;
  stats.diagnose(stat, quietInputs(0, 0, 0, 0), "balanced", 3.0);
  EXPECT_EQ(stat.level, diagnostic_msgs::DiagnosticStatus::ERROR);
  EXPECT_EQ(stat.message, "frames dropped for bad input: OpenCV: boom");
  EXPECT_EQ(valueOf(stat, "rejected"), "3");
  EXPECT_EQ(valueOf(stat, "errors"), "1");
}

TEST(FrameMailbox, KeepsTheLatestFrameAndSaysWhenOneWasReplaced) {
  bdis_stereo::FrameMailbox<int> box;
  EXPECT_FALSE(box.post(1));
  EXPECT_TRUE(box.post(2));  // 1 was still waiting
  int frame = 0;
  ASSERT_TRUE(box.take(frame));
  EXPECT_EQ(frame, 2);
  EXPECT_FALSE(box.post(3));
  ASSERT_TRUE(box.take(frame));
  EXPECT_EQ(frame, 3);
  std::thread stopper([&box] { box.stop(); });
  EXPECT_FALSE(box.take(frame));  // waits until stopped
  stopper.join();
}

// ---- dynamic_reconfigure --------------------------------------------------------

bdis_stereo::BdisStereoConfig configOf(const bdis::MatcherParams& p, const std::string& preset) {
  bdis_stereo::BdisStereoConfig config = bdis_stereo::BdisStereoConfig::__getDefault__();
  config.preset = preset;
  bdis_stereo::paramsToConfig(p, config);
  return config;
}

TEST(MatcherReconfigure, RefusedValuesKeepThePreviousParameters) {
  const bdis::MatcherParams balanced;
  bdis_stereo::MatcherReconfigure reconfigure("test", "balanced", balanced);
  bdis::MatcherParams taken;
  bdis_stereo::BdisStereoConfig config = configOf(balanced, "balanced");
  config.sigma_r = std::numeric_limits<double>::quiet_NaN();  // passes the server's clamp
  reconfigure.reconfigure(config);
  EXPECT_FLOAT_EQ(config.sigma_r, 0.5);  // put back
  EXPECT_FALSE(reconfigure.takeChange(taken));
  config.coarsest_level = 1;
  config.finest_level = 3;
  reconfigure.reconfigure(config);
  EXPECT_EQ(config.coarsest_level, 5);
  EXPECT_EQ(config.finest_level, -1);
  EXPECT_FALSE(reconfigure.takeChange(taken));
  EXPECT_THROW(
      {
        bdis_stereo::BdisStereoConfig bad = configOf(balanced, "balanced");
        bad.window_step = std::numeric_limits<double>::infinity();
        bdis_stereo::paramsFromConfig(bad);
      },
      bdis::ParamError);
}

TEST(MatcherReconfigure, AcceptedChangesReachTheWorkerOnce) {
  bdis_stereo::MatcherReconfigure reconfigure("test", "balanced", bdis::MatcherParams{});
  bdis_stereo::BdisStereoConfig config = configOf(bdis::MatcherParams{}, "balanced");
  config.patch_size = 12;
  reconfigure.reconfigure(config);
  bdis::MatcherParams taken;
  ASSERT_TRUE(reconfigure.takeChange(taken));
  EXPECT_EQ(taken.patch_size, 12);
  EXPECT_FALSE(reconfigure.takeChange(taken));
  // A preset sets every field; an unknown one is kept out.
  config.preset = "accurate";
  reconfigure.reconfigure(config);
  ASSERT_TRUE(reconfigure.takeChange(taken));
  EXPECT_EQ(taken.patch_size, bdis::MatcherParams::preset("accurate").patch_size);
  EXPECT_FLOAT_EQ(config.overlap, 0.7);
  EXPECT_EQ(reconfigure.preset(), "accurate");
  config.preset = "turbo";
  reconfigure.reconfigure(config);
  EXPECT_EQ(config.preset, "accurate");
  EXPECT_FALSE(reconfigure.takeChange(taken));
}

}  // namespace
