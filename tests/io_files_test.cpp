// Outputs written all or nothing: io::FileSet (files written together) and io::OutputFolder (a
// folder of them, as `duolod generate` and `duolod shader` write). Each case checks the whole
// folder afterwards, temporaries and kept copies included.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "duolod/io.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {
namespace fs = std::filesystem;

void writeText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// Every entry under `dir`, relative, sorted; folders end in '/'.
std::vector<std::string> treeOf(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::recursive_directory_iterator(dir))
    names.push_back(entry.path().lexically_relative(dir).string() +
                    (entry.is_directory() ? "/" : ""));
  std::sort(names.begin(), names.end());
  return names;
}

TEST(FileSet, ARenameFailingPartWayPutsEveryFileBack) {
  const fs::path dir = test::scratchDir("fileset_put_back");
  writeText(dir / "a.txt", "old a");
  io::FileSet set;
  ASSERT_TRUE(set.add((dir / "a.txt").string(), std::string_view("new a")));  // replaces a file
  ASSERT_TRUE(set.add((dir / "b.txt").string(), std::string_view("new b")));  // a new file
  ASSERT_TRUE(set.add((dir / "c.txt").string(), std::string_view("new c")));
  // After the files are written, a folder takes c.txt's place: its rename fails, the third.
  fs::create_directory(dir / "c.txt");
  writeText(dir / "c.txt" / "inside", "x");
  auto committed = set.commit();
  ASSERT_FALSE(committed);
  EXPECT_TRUE(test::contains(committed.error().message, "c.txt")) << committed.error().message;
  EXPECT_TRUE(test::contains(committed.error().message, "taken back")) << committed.error().message;
  // a.txt holds its old text again, b.txt is gone, and no temporary or kept copy is left.
  EXPECT_EQ(test::readText(dir / "a.txt"), "old a");
  EXPECT_EQ(treeOf(dir), (std::vector<std::string>{"a.txt", "c.txt/", "c.txt/inside"}));
}

// A valid name of 250 bytes: its temporary (NAME.tmp-PID-RANDOM) would pass the file system's
// 255-byte limit, so the temporary's name is shortened ("File name too long" before).
TEST(FileSet, LongFileNamesAreWritten) {
  const fs::path dir = test::scratchDir("long_names");
  const fs::path target = dir / (std::string(246, 'n') + ".obj");
  ASSERT_EQ(target.filename().string().size(), 250u);
  ASSERT_TRUE(io::writeFileAtomic(target.string(), std::string_view("v 0 0 0\n")));
  EXPECT_EQ(test::readText(target.string()), "v 0 0 0\n");
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) files += entry.is_regular_file();
  EXPECT_EQ(files, 1u);  // no temporary left beside it
}

TEST(FileSet, ACommittedSetLeavesOnlyItsFiles) {
  const fs::path dir = test::scratchDir("fileset_commit");
  writeText(dir / "a.txt", "old a");
  writeText(dir / "other.txt", "someone's");
  io::FileSet set;
  ASSERT_TRUE(set.add((dir / "a.txt").string(), std::string_view("new a")));
  ASSERT_TRUE(set.add((dir / "b.txt").string(), std::string_view("new b")));
  ASSERT_TRUE(set.commit());
  EXPECT_EQ(test::readText(dir / "a.txt"), "new a");
  EXPECT_EQ(test::readText(dir / "b.txt"), "new b");
  EXPECT_EQ(test::readText(dir / "other.txt"), "someone's");
  EXPECT_EQ(treeOf(dir), (std::vector<std::string>{"a.txt", "b.txt", "other.txt"}));
}

TEST(OutputFolder, CommitMovesEveryStagedFileIn) {
  const fs::path parent = test::scratchDir("output_folder_commit");
  const fs::path out = parent / "out";
  fs::create_directory(out);
  writeText(out / "x.txt", "old x");
  writeText(out / "keep.txt", "not this output's");
  io::OutputFolder folder;
  ASSERT_TRUE(folder.begin(out.string() + "/"));  // a trailing '/' names the same folder
  const fs::path staging(folder.stagingPath());
  EXPECT_EQ(staging.parent_path(), out);  // on the folder's file system
  writeText(staging / "x.txt", "new x");
  fs::create_directory(staging / "sub");
  writeText(staging / "sub" / "y.txt", "new y");
  // Nothing is in the folder before the commit.
  EXPECT_EQ(test::readText(out / "x.txt"), "old x");
  EXPECT_FALSE(fs::exists(out / "sub"));
  ASSERT_TRUE(folder.commit());
  EXPECT_EQ(test::readText(out / "x.txt"), "new x");
  EXPECT_EQ(test::readText(out / "sub" / "y.txt"), "new y");
  EXPECT_EQ(test::readText(out / "keep.txt"), "not this output's");
  EXPECT_EQ(treeOf(parent), (std::vector<std::string>{"out/", "out/keep.txt", "out/sub/",
                                                      "out/sub/y.txt", "out/x.txt"}));
}

TEST(OutputFolder, AFailedCommitLeavesTheFolderAsItWas) {
  const fs::path parent = test::scratchDir("output_folder_failed");
  const fs::path out = parent / "out";
  fs::create_directory(out);
  writeText(out / "a.txt", "old a");
  fs::create_directory(out / "z.txt");  // in the way of the last file
  {
    io::OutputFolder folder;
    ASSERT_TRUE(folder.begin(out.string()));
    const fs::path staging(folder.stagingPath());
    writeText(staging / "a.txt", "new a");
    writeText(staging / "b.txt", "new b");
    fs::create_directory(staging / "sub");
    writeText(staging / "sub" / "c.txt", "new c");
    writeText(staging / "z.txt", "new z");
    auto committed = folder.commit();
    ASSERT_FALSE(committed);
    EXPECT_TRUE(test::contains(committed.error().message, "z.txt")) << committed.error().message;
    // The rename failed, the last of the set: a.txt, b.txt and sub/c.txt had been moved in, and
    // were taken back (a.txt's old text restored, sub/ removed again).
    EXPECT_TRUE(test::contains(committed.error().message, "taken back"))
        << committed.error().message;
    EXPECT_EQ(test::readText(out / "a.txt"), "old a");
    EXPECT_EQ(treeOf(out), (std::vector<std::string>{"a.txt", "z.txt/"}));
  }
  // The staging folder goes with the OutputFolder.
  EXPECT_EQ(treeOf(parent), (std::vector<std::string>{"out/", "out/a.txt", "out/z.txt/"}));
}

TEST(OutputFolder, WithoutACommitNothingIsWritten) {
  const fs::path parent = test::scratchDir("output_folder_abandoned");
  fs::create_directory(parent / "kept");
  writeText(parent / "kept" / "old.txt", "old");
  {
    io::OutputFolder folder;
    ASSERT_TRUE(folder.begin((parent / "new" / "out").string()));  // parents are made
    writeText(fs::path(folder.stagingPath()) / "a.txt", "a");
    io::OutputFolder existing;
    ASSERT_TRUE(existing.begin((parent / "kept").string()));
    writeText(fs::path(existing.stagingPath()) / "old.txt", "new");
  }
  // The folders begin() made are gone again, the one that was there keeps its files.
  EXPECT_EQ(treeOf(parent), (std::vector<std::string>{"kept/", "kept/old.txt"}));
  EXPECT_EQ(test::readText(parent / "kept" / "old.txt"), "old");
}

TEST(OutputFolder, RefusesToReplaceTheAssetsFilesAndCreatesNothing) {
  const fs::path parent = test::scratchDir("output_folder_source");
  const fs::path out = parent / "out";
  core::Asset asset;
  asset.source_files = {(out / "texture.png").string()};
  {
    io::OutputFolder folder;
    ASSERT_TRUE(folder.begin(out.string()));
    writeText(fs::path(folder.stagingPath()) / "texture.png", "new");
    auto committed = folder.commit(&asset);
    ASSERT_FALSE(committed);
    EXPECT_TRUE(test::contains(committed.error().message, "read from"))
        << committed.error().message;
  }
  EXPECT_FALSE(fs::exists(out));
}

TEST(OutputFolder, ASymbolicLinkIsFollowed) {
  const fs::path parent = test::scratchDir("output_folder_link");
  fs::create_directory(parent / "real");
  fs::create_directory_symlink(parent / "real", parent / "link");
  io::OutputFolder folder;
  ASSERT_TRUE(folder.begin((parent / "link").string()));
  EXPECT_EQ(fs::path(folder.stagingPath()).parent_path(), parent / "real");
  writeText(fs::path(folder.stagingPath()) / "a.txt", "a");
  ASSERT_TRUE(folder.commit());
  EXPECT_EQ(test::readText(parent / "real" / "a.txt"), "a");
  EXPECT_TRUE(fs::is_symlink(parent / "link"));
}

// A run that was killed left its staging folder; the next one removes it (its process is gone)
// and keeps a live run's.
TEST(OutputFolder, StagingFoldersOfKilledRunsAreRemoved) {
  const fs::path out = test::scratchDir("output_folder_stale");
  // pid_max is at most 2^22 on Linux: this process cannot exist.
  fs::create_directories(out / ".duolod-staging-4999999-12" / "sub");
  const std::string live = ".duolod-staging-" + std::to_string(::getpid()) + "-7";
  fs::create_directory(out / live);
  io::OutputFolder folder;
  ASSERT_TRUE(folder.begin(out.string()));
  EXPECT_FALSE(fs::exists(out / ".duolod-staging-4999999-12"));
  EXPECT_TRUE(fs::exists(out / live));
}

// A dangling symbolic link where the folder would go is the user's: refused, never removed.
TEST(OutputFolder, ADanglingSymbolicLinkIsKept) {
  const fs::path parent = test::scratchDir("output_folder_dangling");
  fs::create_directory_symlink(parent / "nowhere", parent / "out");
  {
    io::OutputFolder folder;
    EXPECT_FALSE(folder.begin((parent / "out").string()));
  }
  EXPECT_TRUE(fs::is_symlink(fs::symlink_status(parent / "out")));
}

TEST(OutputFolder, BadFolderNamesAreRefused) {
  const fs::path parent = test::scratchDir("output_folder_bad");
  writeText(parent / "file", "x");
  io::OutputFolder folder;
  auto not_folder = folder.begin((parent / "file").string());
  ASSERT_FALSE(not_folder);
  EXPECT_TRUE(test::contains(not_folder.error().message, "not a folder"))
      << not_folder.error().message;
  EXPECT_FALSE(folder.begin(""));
  EXPECT_FALSE(folder.begin("/"));
  EXPECT_FALSE(folder.commit());  // not begun
  EXPECT_EQ(treeOf(parent), std::vector<std::string>{"file"});
}

// A program that asked for it (the CLI does) removes its unfinished outputs when interrupted: the
// staging folder, the folders OutputFolder::begin made and FileSet temporaries, and exits with
// 128 + the signal. (Before, a killed `duolod generate` left its hidden staging folder and the
// folders it had made for --out.) Run in a child process, which the test then interrupts.
struct Interrupted {
  int exit_code = -1;
  std::string err;
};
Interrupted interruptChild(const fs::path& dir, int signal, bool with_outputs) {
  int ready[2];
  if (::pipe(ready) != 0) return {};
  const fs::path err_path = dir / ("stderr-" + std::to_string(signal) + ".txt");
  const pid_t child = ::fork();
  if (child == 0) {
    ::close(ready[0]);
    std::FILE* err = std::freopen(err_path.c_str(), "w", stderr);
    (void)err;
    io::removeUnfinishedOutputsOnInterrupt();
    io::OutputFolder folder;
    io::FileSet single;
    if (with_outputs) {
      if (!folder.begin((dir / "made" / "deeper" / "out").string()).ok()) ::_exit(90);
      writeText(fs::path(folder.stagingPath()) / "lod.json", "{}");
      if (!single.add((dir / "single.txt").string(), std::string_view("text")).ok()) ::_exit(91);
    }
    const char byte = 1;
    if (::write(ready[1], &byte, 1) != 1) ::_exit(92);
    for (;;) ::pause();  // until the signal ends the process
  }
  ::close(ready[1]);
  char byte = 0;
  const bool started = ::read(ready[0], &byte, 1) == 1;
  ::close(ready[0]);
  if (started)
    ::kill(child, signal);
  else
    ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1000 - WTERMSIG(status),
          test::readText(err_path)};
}

TEST(OutputFolder, AnInterruptedProgramRemovesItsUnfinishedOutputs) {
  const fs::path dir = test::scratchDir("io_files_interrupt");
  writeText(dir / "keep.txt", "the user's");
  const Interrupted terminated = interruptChild(dir, SIGTERM, true);
  EXPECT_EQ(terminated.exit_code, 128 + SIGTERM) << terminated.err;
  EXPECT_TRUE(
      test::contains(terminated.err, "interrupted (SIGTERM); removed the unfinished output"))
      << terminated.err;
  EXPECT_TRUE(test::contains(terminated.err, "made")) << terminated.err;
  // Only what was there before is left (and the children's stderr).
  EXPECT_EQ(treeOf(dir), (std::vector<std::string>{"keep.txt", "stderr-15.txt"}));

  const Interrupted interrupted = interruptChild(dir, SIGINT, false);
  EXPECT_EQ(interrupted.exit_code, 128 + SIGINT) << interrupted.err;
  EXPECT_TRUE(test::contains(interrupted.err, "no unfinished output to remove")) << interrupted.err;
}

}  // namespace
}  // namespace duolod
