// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Settings in ORB-SLAM3's YAML style fill the core's parameters: present keys override, absent
// keys keep the defaults, wrong keys and values are errors that name the file and the key.
#include "rvwo/settings/settings.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "../common/temp.h"

namespace rvwo {
namespace {

namespace fs = std::filesystem;

template <typename F>
void expectError(F&& f, const std::string& fragment) {
  try {
    f();
    FAIL() << "no error; expected: " << fragment;
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(Settings, ReliabilityAndOdometryFromYaml) {
  const Settings s = Settings::fromString(
      "%YAML:1.0\nCamera1.fx: 458.654\nReliability.Ph: 0.8\nReliability.a: -6\nOdometry.NoiseX: 0.05\n", "robot.yaml");
  EXPECT_EQ(s.requireNumber("Camera1.fx"), 458.654);
  const ReliabilityParams r = readReliability(s);
  EXPECT_EQ(r.p_h, 0.8);
  EXPECT_EQ(r.a, -6.0);
  EXPECT_EQ(r.b, ReliabilityParams().b);  // absent: the paper's default
  const WheelNoise n = readWheelNoise(s);
  EXPECT_EQ(n.sigma_x, 0.05);
  EXPECT_EQ(n.sigma_y, WheelNoise().sigma_y);
}

TEST(Settings, ErrorsNameTheFileAndTheKey) {
  expectError([] { Settings::fromString("%YAML:1.0\nCamera1.fy: 1\n", "cam.yaml").requireNumber("Camera1.fx"); },
              "cam.yaml: missing key Camera1.fx");
  expectError([] { readReliability(Settings::fromString("%YAML:1.0\nReliability.Ph: \"high\"\n", "r.yaml")); },
              "r.yaml: Reliability.Ph must be a number");
  expectError([] { readReliability(Settings::fromString("%YAML:1.0\nReliability.Phh: 0.9\n", "r.yaml")); },
              "r.yaml: unknown key Reliability.Phh");
  expectError([] { readReliability(Settings::fromString("%YAML:1.0\nReliability.Ws: 0.7\n", "r.yaml")); },
              "r.yaml: Reliability.Wo");
  expectError([] { readWheelNoise(Settings::fromString("%YAML:1.0\nOdometry.NoiseY: -1\n", "o.yaml")); },
              "o.yaml: Odometry.NoiseY");
  expectError([] { Settings::load(rvwo::test::scratch("rvwo_no_such_folder/settings.yaml").string()); },
              "settings file not found");
  const fs::path bad = rvwo::test::scratch("rvwo_bad_settings.yaml");
  std::ofstream(bad) << "this: [is not closed\n";
  expectError([&] { Settings::load(bad.string()); },
              bad.string() + ": not a settings YAML file (its first line must be %YAML:1.0)");
  fs::remove(bad);
}

// A YAML syntax error names its line; a key given twice (an override appended at the end, which
// the reader would have ignored) is an error naming both lines, whatever the file or text.
TEST(Settings, SyntaxErrorsAndKeysGivenTwiceNameTheirLines) {
  const fs::path bad = rvwo::test::scratch("rvwo_syntax.yaml");
  const auto errorOf = [&](const std::string& text) {
    std::ofstream(bad) << text;
    try {
      Settings::load(bad.string());
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("loaded");
  };
  EXPECT_EQ(errorOf("%YAML:1.0\nA: 1\nB 2\nC: 3\n"), bad.string() + ": line 3: Missing ':'");
  EXPECT_EQ(errorOf("%YAML:1.0\nA: 1\n  B: 2\n"), bad.string() + ": line 3: Incorrect indentation");
  EXPECT_EQ(errorOf("%YAML:1.0\nCamera1.fx: 400\nM: !!opencv-matrix\n  rows: 1\n  cols: 1\n  dt: d\n  data: [1]\n"
                    "# Camera1.fx: 1\nCamera1.fx: 500\n"),
            bad.string() + ": Camera1.fx is given twice (lines 2 and 9): keep one");
  EXPECT_EQ(errorOf("%YAML:1.0\nA: 1\n\"A\": 2\n"), bad.string() + ": A is given twice (lines 2 and 3): keep one");
  // Fields of two matrices and keys under different sections are not top-level keys.
  EXPECT_EQ(errorOf("%YAML:1.0\nM: !!opencv-matrix\n  rows: 1\n  cols: 1\n  dt: d\n  data: [1]\n"
                    "N: !!opencv-matrix\n  rows: 1\n  cols: 1\n  dt: d\n  data: [2]\n"),
            "loaded");
  // OpenCV's parser looped for ever on this one (fuzzing found it): refused before it reads.
  EXPECT_EQ(errorOf("%YAML:1.0\n# a comment\n\n   data: []\nOdo-e:1.0\n"),
            bad.string() + ": line 4: the first key is indented (top-level keys start in the first column)");
  // And when keys begin on the '---' line, or text follows the document's end (fuzzing found the
  // first, tests/fuzz/regressions/settings/keys-on-the-document-line-opencv-loops.yaml).
  EXPECT_EQ(errorOf("%YAML:1.0\n---M:C\n--'-\n"),
            bad.string() + ": line 2: text after '---' on its line (start the keys on the next line)");
  EXPECT_EQ(errorOf("%YAML:1.0\n---\nA: 1\n...\n-\n"),
            bad.string() + ": line 5: text after the document's end ('...'): a settings file is one document");
  // A second document, which the reader would not have read, is refused the same way.
  EXPECT_EQ(errorOf("%YAML:1.0\n---\nA: 1\n...\n---\nB: 2\n"),
            bad.string() + ": line 5: text after the document's end ('...'): a settings file is one document");
  EXPECT_EQ(errorOf("%YAML:1.0\n--- # a comment\nA: 1\n...\n# the end\n"), "loaded");
  // And on a NUL amid keys (fuzzing found it, tests/fuzz/regressions/settings/opencv_loop_on_nul):
  // a control character YAML does not allow is refused with its line; CRs are not.
  EXPECT_EQ(errorOf(std::string("%YAML:1.0\nA: 1\nB: \0\0x\n", 20)),
            bad.string() + ": line 3: a control character (byte 0x00): a settings file is text (a damaged copy?)");
  EXPECT_EQ(errorOf("%YAML:1.0\r\nA: 1\r\n"), "loaded");
  expectError([] { Settings::fromString("%YAML:1.0\nA: 1\nA: 2\n", "t.yaml"); },
              "t.yaml: A is given twice (lines 2 and 3): keep one");
  fs::remove(bad);
}

// A matrix of the wrong shape is refused before OpenCV reads it: OpenCV allocates the rows and
// columns the file states (a damaged "cols: N" once asked for 64 GB; fuzzing found it).
TEST(Settings, MatrixOfAnotherShapeIsRefusedBeforeItIsRead) {
  const auto matrix = [](const std::string& rows, const std::string& cols, const std::string& data) {
    return Settings::fromString("%YAML:1.0\nM: !!opencv-matrix\n  rows: " + rows + "\n  cols: " + cols +
                                    "\n  dt: d\n  data: [" + data + "]\n",
                                "m.yaml")
        .matrix("M", 2, 2);
  };
  EXPECT_EQ(*matrix("2", "2", "1, 2, 3, 4"), (std::vector<double>{1, 2, 3, 4}));
  const std::string wrong = "m.yaml: M must be a 2x2 !!opencv-matrix";
  expectError([&] { matrix("4", "N", "1, 2, 3, 4"); }, wrong);  // 4 x 2^31 doubles (under ASan, an abort)
  expectError([&] { matrix("1", "4", "1, 2, 3, 4"); }, wrong);
  expectError([&] { matrix("2", "2", "1, 2, 3"); }, wrong);
  expectError([] { Settings::fromString("%YAML:1.0\nM: [1, 2, 3, 4]\n", "m.yaml").matrix("M", 2, 2); }, wrong);
}

TEST(Settings, SemanticPriorsFromYamlAndAUserFile) {
  const fs::path dir = rvwo::test::scratch("rvwo_settings_test");
  fs::create_directories(dir);
  std::ofstream(dir / "priors.txt") << "# our robot's world\nchair: 0.7\n";
  std::ofstream(dir / "s.yaml")
      << "%YAML:1.0\nSemantics.LabelSet: \"ade20k150\"\nSemantics.PriorsFile: \"priors.txt\"\n"
         "Semantics.Prior.door: 0.2\n";
  const SemanticPriors p = readSemanticPriors(Settings::load((dir / "s.yaml").string()));
  EXPECT_EQ(p.name(), "ade20k150");
  EXPECT_EQ(p.prior(p.labelOf("chair")), 0.7);  // from the file, relative to the settings
  EXPECT_EQ(p.prior(p.labelOf("door")), 0.2);
  EXPECT_EQ(p.prior(p.labelOf("person")), 0.95);
  // A file named in the settings: relative to their folder, made absolute; an absolute one as given.
  const Settings files =
      Settings::fromString("%YAML:1.0\nA: \"m/net.onnx\"\nB: \"/opt/net.onnx\"\n", (dir / "f.yaml").string());
  EXPECT_EQ(*files.file("A"), fs::absolute(dir / "m" / "net.onnx").string());
  EXPECT_EQ(*files.file("B"), "/opt/net.onnx");
  EXPECT_FALSE(files.file("C"));
  EXPECT_EQ(readSemanticPriors(Settings::fromString("%YAML:1.0\nX: 1\n")).name(), "voc21");
  expectError([] { readSemanticPriors(Settings::fromString("%YAML:1.0\nSemantics.Prior.unicorn: 0.5\n", "u.yaml")); },
              "u.yaml: Semantics.Prior.unicorn: class 'unicorn' is not in label set 'voc21'");
  expectError(
      [] { readSemanticPriors(Settings::fromString("%YAML:1.0\nSemantics.LabelSet: \"cityscapes\"\n", "l.yaml")); },
      "l.yaml: Semantics.LabelSet: unknown label set 'cityscapes'");
}

// Tracking.*: both hosts' one namespace. The estimator's old names are still read, each with one
// line of warning (once per file and key); both names given is an error; what
// writeTrackingOptions writes reads back the same.
TEST(Settings, TrackingOptionsUnderTheirNameAndTheOldOne) {
  const Settings s = Settings::fromString(
      "%YAML:1.0\nTracking.MinInliers: 25\nTracking.WheelGate: 0\nEstimator.TrustedMaxPs: 0.2\n"
      "Estimator.SigmaRollPitch: 0.02\n",
      "t.yaml");
  std::ostringstream warnings;
  TrackingOptions defaults;
  defaults.slip_hold = 1.5;  // the host's default where the file is silent
  const TrackingOptions o = readTrackingOptions(s, defaults, &warnings);
  EXPECT_EQ(o.min_inliers, 25);
  EXPECT_FALSE(o.wheel_gate);
  EXPECT_DOUBLE_EQ(o.trusted_max_ps, 0.2);
  EXPECT_DOUBLE_EQ(o.sigma_rollpitch, 0.02);
  EXPECT_DOUBLE_EQ(o.slip_hold, 1.5);
  EXPECT_TRUE(o.slip_check);
  EXPECT_EQ(warnings.str(),
            "t.yaml: Estimator.TrustedMaxPs is now Tracking.TrustedMaxPs (read under its old name for now; rename "
            "it)\nt.yaml: Estimator.SigmaRollPitch is now Tracking.SigmaRollPitch (read under its old name for now; "
            "rename it)\n");
  std::ostringstream again;
  readTrackingOptions(s, {}, &again);
  EXPECT_EQ(again.str(), "");  // once per file and key

  auto message = [](const std::string& body) {
    try {
      std::ostringstream ignored;
      readTrackingOptions(Settings::fromString("%YAML:1.0\n" + body, "b.yaml"), {}, &ignored);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message("Tracking.SlipHold: 1\nEstimator.SlipHold: 3\n"),
            "b.yaml: Tracking.SlipHold and its old name Estimator.SlipHold are both given; keep Tracking.SlipHold");
  EXPECT_EQ(message("Tracking.MinInliers: 20.5\n"), "b.yaml: Tracking.MinInliers must be a whole number");
  EXPECT_EQ(message("Tracking.MinInliers: 3\n"), "b.yaml: tracking options: Tracking.MinInliers: >= 6");
  EXPECT_EQ(message("Tracking.BarronScale: 0\n"), "b.yaml: tracking options: Tracking.BarronScale: > 0");

  TrackingOptions w;
  w.min_inliers = 30;
  w.slip_min_inliers = 2.5;
  w.trusted_max_ps = 0.1;
  w.slip_check = false;
  w.sigma_z = 0.013;
  std::ostringstream yaml;
  yaml << "%YAML:1.0\n";
  writeTrackingOptions(yaml, w);
  std::ostringstream none;
  const TrackingOptions r = readTrackingOptions(Settings::fromString(yaml.str(), "w.yaml"), {}, &none);
  EXPECT_EQ(r.min_inliers, 30);
  EXPECT_EQ(r.slip_min_inliers, 2.5);
  EXPECT_EQ(r.trusted_max_ps, 0.1);
  EXPECT_FALSE(r.slip_check);
  EXPECT_EQ(r.sigma_z, 0.013);
  EXPECT_EQ(r.slip_hold, w.slip_hold);
  EXPECT_EQ(none.str(), "");
}

}  // namespace
}  // namespace rvwo
