// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// What an app writes: whole or not at all (a write that fails leaves the old file and no partial
// one), and never over one of its inputs.
#include "support/output.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "../common/temp.h"

namespace rvwo::apps {
namespace {

namespace fs = std::filesystem;
using rvwo::test::slurp;

TEST(Output, WrittenWholeOrNotAtAll) {
  const fs::path dir = rvwo::test::scratch("output");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string path = (dir / "traj.txt").string();
  std::ofstream(path) << "old\n";
  EXPECT_EQ(partialPath(path), (dir / ".traj.partial.txt").string());
  // A writer that fails half way: the old file stays, the partial one is gone.
  EXPECT_THROW(writeWhole(path,
                          [](const std::string& tmp) {
                            std::ofstream(tmp) << "half";
                            throw std::runtime_error("disk full");
                          }),
               std::runtime_error);
  EXPECT_EQ(slurp(path), "old\n");
  EXPECT_FALSE(fs::exists(partialPath(path)));
  // One that succeeds replaces it.
  writeWhole(path, [](const std::string& tmp) { std::ofstream(tmp) << "new\n"; });
  EXPECT_EQ(slurp(path), "new\n");
  EXPECT_FALSE(fs::exists(partialPath(path)));
  fs::remove_all(dir);
}

TEST(Output, AnOutputThatIsAnInputOrCannotBeWrittenIsRefused) {
  const fs::path dir = rvwo::test::scratch("output_check");
  fs::remove_all(dir);
  fs::create_directories(dir / "sub");
  std::ofstream(dir / "in.txt") << "x";
  fs::create_symlink(dir / "in.txt", dir / "link.txt");
  fs::create_hard_link(dir / "in.txt", dir / "hard.txt");
  const std::vector<PathArg> inputs{{"--gt", ""}, {"--rawlog", (dir / "in.txt").string()}};
  const auto message = [&](const std::string& out) {
    try {
      checkOutputs({{"--out", out}}, inputs);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const std::string in = (dir / "in.txt").string();
  EXPECT_EQ(message(in), "--out " + in + " is the --rawlog input: give the output another path");
  EXPECT_EQ(
      message((dir / "sub" / ".." / "in.txt").string()),
      "--out " + (dir / "sub" / ".." / "in.txt").string() + " is the --rawlog input: give the output another path");
  EXPECT_NE(message((dir / "link.txt").string()).find("is the --rawlog input"), std::string::npos);
  EXPECT_NE(message((dir / "hard.txt").string()).find("is the --rawlog input"), std::string::npos);
  EXPECT_EQ(message((dir / "sub").string()), "--out " + (dir / "sub").string() + " is a folder: give a file name");
  EXPECT_EQ(message((dir / "none" / "t.txt").string()), "--out " + (dir / "none" / "t.txt").string() + ": no folder " +
                                                            (dir / "none").string() +
                                                            " (make it, or give another path)");
  EXPECT_EQ(message((dir / "t.txt").string()), "accepted");
  EXPECT_EQ(message(""), "accepted");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rvwo::apps
