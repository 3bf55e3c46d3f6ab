// bdis_synth: renders a synthetic rectified stereo sequence of an endoscopic
// scene with exact ground-truth disparity, in the layout of the shared data
// folder (left/, right/, gt_disparity/, camera.yaml), plus labels/ (the surface
// each left pixel sees, for bdis_eval's rows beside the instrument). Same
// settings, same bytes.
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "bdis_stereo/synthetic_scene.hpp"
#include "tool_common.hpp"

namespace {

using namespace bdis;
using namespace bdis::tools;

constexpr const char* kUsage = R"(usage: bdis_synth --out DIR [options]

Renders a rectified stereo sequence with exact ground truth into DIR:
left/ and right/ (8-bit BGR PNG), gt_disparity/ (16-bit PNG, d * 256, 0 = unknown),
labels/ (8-bit PNG, the surface each left pixel sees: 0 none, 1 tissue, 2 instrument)
and camera.yaml. Scene units are metres. The defaults give the demo's sample:
a breathing tissue surface, specular lighting, an instrument, 30 frames at 640x480.

options:
  --out DIR              output folder (created; refused if it holds frames, see --overwrite)
  --variant NAME         start from a named configuration (default: sample, the demo's);
                         the options below override it
  --list-variants        print the variants' names, one per line, and exit
  --scene NAME           tissue | tube
  --lighting NAME        diffuse | specular
  --frames N             number of frames (30 frames per second of scene time)
  --width W --height H   image size in px (default 640 x 480)
  --focal F              fx = fy in px (default 0.8125 * width: 520 px at 640)
  --baseline B           stereo baseline in m (default 0.005)
  --noise SIGMA          Gaussian sensor noise, grey levels (default 2; 0 = none)
  --seed S               scene layout, texture and noise (default 1)
  --instrument | --no-instrument       surgical instrument in view (default on)
  --borders | --no-borders             black rectification borders (default on)
  --textureless-patch    an albedo-flat disk on the tissue (tissue scene)
  --spot K               scope light beam falloff cos^K (default 2)
  --exposure E           light power factor (default 1)
  --right-gain G         the right view's grey levels times G, 0.5..2: a gain difference
                         between the cameras (default 1)
  --motion M             motion speed factor, 0 = static (default 1)
  --supersampling N      N x N samples on edges and highlight borders (default 3)
  --jpeg-quality Q       store each view as a JPEG of quality Q, 1..100, decoded (default 0: not)
  --overwrite            replace the NNNNNN.png frames already in DIR
  -q, --quiet            no progress bar
)";

/// The parsers of the scene library throw std::invalid_argument: a usage error here.
template <typename F>
auto asUsageError(F parse) {
  try {
    return parse();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
}

int toInt(const std::string& opt, const std::string& text) {
  const long long v = parseInteger(opt, text);
  if (v < -1000000000LL || v > 1000000000LL) throw UsageError(opt + " = " + text + " is out of range");
  return static_cast<int>(v);
}

int run(int argc, char** argv) {
  std::string out;
  bool overwrite = false, quiet = false;
  // The variant is applied first, whatever its position; the rest in order.
  synth::SceneConfig cfg;
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--variant") {
      const std::string name = optionValue(i, argc, argv);
      try {
        cfg = synth::SceneConfig::variant(name);
      } catch (const std::invalid_argument& e) {
        throw UsageError(e.what());
      }
    }
  }
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::cout << kUsage;
      return 0;
    } else if (a == "--list-variants") {
      for (const std::string& name : synth::SceneConfig::variantNames()) std::cout << name << '\n';
      return 0;
    } else if (a == "--variant") {
      ++i;
    } else if (a == "--out") {
      out = optionValue(i, argc, argv);
    } else if (a == "--scene") {
      cfg.scene = asUsageError([&] { return synth::parseSceneType(optionValue(i, argc, argv)); });
    } else if (a == "--lighting") {
      cfg.lighting = asUsageError([&] { return synth::parseLighting(optionValue(i, argc, argv)); });
    } else if (a == "--frames") {
      cfg.frames = toInt(a, optionValue(i, argc, argv));
    } else if (a == "--width") {
      cfg.width = toInt(a, optionValue(i, argc, argv));
    } else if (a == "--height") {
      cfg.height = toInt(a, optionValue(i, argc, argv));
    } else if (a == "--focal") {
      cfg.focal = parseDouble(a, optionValue(i, argc, argv));
    } else if (a == "--baseline") {
      cfg.baseline = parseDouble(a, optionValue(i, argc, argv));
    } else if (a == "--noise") {
      cfg.noise = parseDouble(a, optionValue(i, argc, argv));
    } else if (a == "--seed") {
      const long long s = parseInteger(a, optionValue(i, argc, argv));
      if (s < 0) throw UsageError("--seed must be >= 0");
      cfg.seed = static_cast<uint64_t>(s);
    } else if (a == "--instrument") {
      cfg.instrument = true;
    } else if (a == "--no-instrument") {
      cfg.instrument = false;
    } else if (a == "--borders") {
      cfg.black_borders = true;
    } else if (a == "--no-borders") {
      cfg.black_borders = false;
    } else if (a == "--textureless-patch") {
      cfg.textureless_patch = true;
    } else if (a == "--spot") {
      cfg.light_spot = parseDouble(a, optionValue(i, argc, argv));
    } else if (a == "--exposure") {
      cfg.exposure = parseDouble(a, optionValue(i, argc, argv));
    } else if (a == "--right-gain") {
      cfg.right_gain = parseDouble(a, optionValue(i, argc, argv));
    } else if (a == "--motion") {
      cfg.motion = parseDouble(a, optionValue(i, argc, argv));
    } else if (a == "--supersampling") {
      cfg.supersampling = toInt(a, optionValue(i, argc, argv));
    } else if (a == "--jpeg-quality") {
      cfg.jpeg_quality = toInt(a, optionValue(i, argc, argv));
    } else if (a == "--overwrite") {
      overwrite = true;
    } else if (a == "-q" || a == "--quiet") {
      quiet = true;
    } else {
      throw UsageError(a.empty() || a[0] != '-' ? "unexpected argument '" + a + "'" : "unknown option " + a);
    }
  }
  if (out.empty()) throw UsageError("--out DIR is required");
  try {
    cfg.validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }

  const double t0 = nowMs();
  std::unique_ptr<ProgressBar> bar;
  if (!quiet) bar = std::make_unique<ProgressBar>(static_cast<size_t>(cfg.frames), "bdis_synth");
  synth::writeSequence(cfg, out, overwrite, [&](int done) {
    if (bar) bar->update(static_cast<size_t>(done));
  });
  if (bar) bar->finish();
  const double ms = nowMs() - t0;
  std::printf("wrote %d frames %dx%d (%s, %s%s) to %s: %.0f ms/frame\n", cfg.frames, cfg.width, cfg.height,
              synth::toString(cfg.scene), synth::toString(cfg.lighting), cfg.instrument ? ", instrument" : "",
              out.c_str(), ms / cfg.frames);
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return runGuarded("bdis_synth", [&] { return run(argc, argv); }); }
