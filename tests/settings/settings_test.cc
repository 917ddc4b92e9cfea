// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Settings in ORB-SLAM3's YAML style fill the core's parameters: present keys override, absent
// keys keep the defaults, wrong keys and values are errors that name the file and the key.
#include "rvwo/settings/settings.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

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
  expectError([&] { Settings::load(bad.string()); }, bad.string() + ": ");
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

}  // namespace
}  // namespace rvwo
