// The `apo` launcher (cli/launcher.cpp) against a stand-in engine: a shell
// script that prints the tunables it was given and its arguments, one per
// line, so that what the launcher passes on is checked as the engine sees it.
#include "tests/test_support.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>
#include <string>

namespace apo {
namespace {

namespace fs = std::filesystem;

// The launcher copied to `launcher`, and a stand-in engine at `engine`.
void install(const fs::path& launcher, const fs::path& engine) {
  fs::create_directories(launcher.parent_path());
  fs::copy_file(test::apoExecutable(), launcher);
  test::writeBytes(engine, "#!/bin/sh\nprintf 'tunables=%s\\n' \"$GLIBC_TUNABLES\"\nfor a in \"$@\"; do printf '[%s]\\n' \"$a\"; done\n");
  fs::permissions(engine, fs::perms::owner_all);
}

std::string run(const fs::path& launcher, const std::string& environment = "env -u GLIBC_TUNABLES") {
  const test::CommandResult result =
      test::runCommand(fmt::format("{} '{}' bake 'two words' '$HOME' --x", environment, launcher.string()));
  EXPECT_EQ(result.exitCode, 0) << result.output;
  return result.output;
}

TEST(Launcher, StartsTheEngineBesideItWithTheHugePageTunableAndEveryArgument) {
  const fs::path dir = test::freshTempDir();
  install(dir / "apo", dir / "apo-engine");
  EXPECT_EQ(run(dir / "apo"), "tunables=glibc.malloc.hugetlb=1\n[bake]\n[two words]\n[$HOME]\n[--x]\n");
}

TEST(Launcher, FindsTheInstalledEngineInLibApo) {
  const fs::path dir = test::freshTempDir();
  install(dir / "bin" / "apo", dir / "lib" / "apo" / "apo-engine");
  EXPECT_EQ(run(dir / "bin" / "apo"), "tunables=glibc.malloc.hugetlb=1\n[bake]\n[two words]\n[$HOME]\n[--x]\n");
}

TEST(Launcher, KeepsTheCallersTunables) {
  const fs::path dir = test::freshTempDir();
  install(dir / "apo", dir / "apo-engine");
  EXPECT_EQ(run(dir / "apo", "GLIBC_TUNABLES=glibc.malloc.hugetlb=0"),
            "tunables=glibc.malloc.hugetlb=0\n[bake]\n[two words]\n[$HOME]\n[--x]\n");
  EXPECT_EQ(run(dir / "apo", "GLIBC_TUNABLES=glibc.malloc.arena_max=2"),
            "tunables=glibc.malloc.arena_max=2:glibc.malloc.hugetlb=1\n[bake]\n[two words]\n[$HOME]\n[--x]\n");
}

TEST(Launcher, NamesWhereItLookedWhenTheEngineIsMissing) {
  const fs::path dir = test::freshTempDir();
  fs::copy_file(test::apoExecutable(), dir / "apo");
  const test::CommandResult result = test::runCommand(fmt::format("'{}' --version", (dir / "apo").string()));
  EXPECT_EQ(result.exitCode, 3);
  EXPECT_NE(result.output.find((dir / "apo-engine").string()), std::string::npos) << result.output;
  EXPECT_NE(result.output.find((dir / ".." / "lib" / "apo" / "apo-engine").string()), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("No such file or directory"), std::string::npos) << result.output;
}

TEST(Launcher, TheRealEngineAnswers) {
  const test::CommandResult result = test::runApo("--version");
  EXPECT_EQ(result.exitCode, 0) << result.output;
  EXPECT_TRUE(std::regex_match(result.output, std::regex("[0-9]+\\.[0-9]+\\.[0-9]+\n"))) << result.output;
}

}  // namespace
}  // namespace apo
