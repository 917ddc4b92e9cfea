// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The ORB-SLAM3 patch set (patches/orbslam3/) without ORB-SLAM3: every patch is a well-formed
// `git format-patch` file (a subject, hunks whose line counts match their headers, so that
// `git apply` reads them), numbered 0001, 0002, ... with no gap, and the set stays within the
// integration issue's budget of lines in upstream files (at most 150 added, 20 changed). That the
// patches apply to a pristine v1.0 tree and build is checked by hand (patches/orbslam3/README.md).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

const fs::path kDir = fs::path(RVWO_SOURCE_DIR) / "patches" / "orbslam3";

struct PatchStats {
  int added = 0, removed = 0, hunks = 0, files = 0;
  bool subject = false;
  std::vector<std::string> errors;
};

// Reads a unified diff as git writes it and checks each hunk's counts against its header.
PatchStats readPatch(const fs::path& path) {
  PatchStats s;
  std::ifstream in(path);
  std::string line;
  const std::regex hunk(R"(^@@ -(\d+)(?:,(\d+))? \+(\d+)(?:,(\d+))? @@.*)");
  int old_left = 0, new_left = 0, n = 0;
  bool in_hunk = false, in_diff = false;
  while (std::getline(in, line)) {
    ++n;
    const std::string where = path.filename().string() + ":" + std::to_string(n);
    if (in_hunk && (old_left > 0 || new_left > 0)) {
      if (line.empty() || line[0] == ' ') {
        --old_left;
        --new_left;
      } else if (line[0] == '-') {
        --old_left;
        ++s.removed;
      } else if (line[0] == '+') {
        --new_left;
        ++s.added;
      } else if (line[0] == '\\') {
        // "\ No newline at end of file"
      } else {
        s.errors.push_back(where + ": hunk ends early");
        in_hunk = false;
      }
      if (old_left < 0 || new_left < 0) s.errors.push_back(where + ": hunk longer than its header says");
      continue;
    }
    in_hunk = false;
    std::smatch m;
    if (line.rfind("Subject: [PATCH", 0) == 0) s.subject = true;
    if (line.rfind("diff --git a/", 0) == 0) {
      ++s.files;
      in_diff = true;
    } else if (in_diff && std::regex_match(line, m, hunk)) {
      old_left = m[2].matched ? std::stoi(m[2]) : 1;
      new_left = m[4].matched ? std::stoi(m[4]) : 1;
      in_hunk = true;
      ++s.hunks;
    }
  }
  if (in_hunk && (old_left != 0 || new_left != 0))
    s.errors.push_back(path.filename().string() + ": last hunk cut short");
  return s;
}

std::vector<fs::path> patches() {
  std::vector<fs::path> out;
  if (!fs::exists(kDir)) return out;
  for (const auto& e : fs::directory_iterator(kDir))
    if (e.path().extension() == ".patch") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

TEST(OrbSlam3Patches, WellFormedNumberedAndWithinBudget) {
  const std::vector<fs::path> all = patches();
  ASSERT_FALSE(all.empty()) << "no patches in " << kDir;
  int added = 0, removed = 0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    char number[32];
    std::snprintf(number, sizeof number, "%04zu-", i + 1);
    EXPECT_EQ(all[i].filename().string().rfind(number, 0), 0u) << all[i] << ": expected number " << number;
    const PatchStats s = readPatch(all[i]);
    EXPECT_TRUE(s.subject) << all[i] << ": no 'Subject: [PATCH' line (git format-patch)";
    EXPECT_GT(s.files, 0) << all[i];
    EXPECT_GT(s.hunks, 0) << all[i];
    for (const std::string& e : s.errors) ADD_FAILURE() << e;
    std::printf("[ figures  ] %-45s +%d -%d lines, %d files, %d hunks\n", all[i].filename().c_str(), s.added, s.removed,
                s.files, s.hunks);
    added += s.added;
    removed += s.removed;
  }
  std::printf("[ figures  ] the set: %d lines added, %d changed in upstream files\n", added, removed);
  EXPECT_LE(added, 150);
  EXPECT_LE(removed, 20);
}

// The checker itself: a hunk whose header promises more lines than it has is caught.
TEST(OrbSlam3Patches, CheckerCatchesABrokenHunk) {
  const fs::path bad = fs::temp_directory_path() / "rvwo_bad.patch";
  {
    std::ofstream out(bad);
    out << "Subject: [PATCH] x\n---\ndiff --git a/f b/f\n--- a/f\n+++ b/f\n@@ -1,3 +1,4 @@\n a\n+b\n c\n";
  }
  const PatchStats s = readPatch(bad);
  EXPECT_FALSE(s.errors.empty());
  fs::remove(bad);
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// What the patches call into RVWO (rvwo::orbslam3::..., Tracking's mWheels.<method>(), the
// headers they include) is declared by plugins/orbslam3: a renamed plugin function breaks the
// ORB-SLAM3 build, which CI does not run, so it is caught here.
TEST(OrbSlam3Patches, CallOnlyWhatThePluginDeclares) {
  const fs::path include = fs::path(RVWO_SOURCE_DIR) / "plugins" / "orbslam3" / "include" / "rvwo" / "orbslam3";
  std::string headers;
  for (const auto& e : fs::directory_iterator(include)) headers += slurp(e.path());
  ASSERT_FALSE(headers.empty()) << include;
  const std::regex call(R"((?:rvwo::orbslam3::|mWheels\.)(\w+))"), inc(R"(#include <rvwo/orbslam3/(\w+\.h)>)");
  int uses = 0;
  for (const fs::path& patch : patches()) {
    std::ifstream in(patch);
    std::string line;
    while (std::getline(in, line)) {
      if (line.rfind("+", 0) != 0 || line.rfind("+++", 0) == 0) continue;
      for (std::sregex_iterator m(line.begin(), line.end(), call), end; m != end; ++m) {
        const std::string name = (*m)[1];
        const std::regex declared("(\\b" + name + "\\s*\\()|((struct|class) " + name + "\\b)");
        EXPECT_TRUE(std::regex_search(headers, declared)) << patch.filename() << " uses " << name;
        ++uses;
      }
      std::smatch m;
      if (std::regex_search(line, m, inc)) {
        EXPECT_TRUE(fs::exists(include / m[1].str())) << patch.filename() << " includes " << m[1];
        ++uses;
      }
    }
  }
  std::printf("[ figures  ] %d uses of the plugin in the patches\n", uses);
  EXPECT_GE(uses, 10);
}

TEST(OrbSlam3Patches, CarryTheirOwnLicence) {
  std::ifstream in(kDir / "LICENSE");
  ASSERT_TRUE(in.good()) << "patches/orbslam3/LICENSE";
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("GNU GENERAL PUBLIC LICENSE"), std::string::npos);
  EXPECT_NE(text.find("Version 3"), std::string::npos);
}

}  // namespace
