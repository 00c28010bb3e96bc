// The checked writer (core/common/checked_file.h) under real failures: a
// file size limit (RLIMIT_FSIZE, write() fails with EFBIG, no privileges
// needed) and, when the test runs as root, a full 64 KiB tmpfs (ENOSPC).
// Also the cloud writer on top of it, which used to report success after a
// failed write (PCL's PLY writer) or abort (PCL's PCD writer).
#include "core/common/checked_file.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/cloud/cloud_io.h"
#include "tests/testing/remove_at_exit.h"

namespace sweepscan {
namespace {

std::string TempDir(const std::string& name) {
  const std::string dir = ::testing::TempDir() + "/checked_file_" + name + "_" +
                          std::to_string(::getpid());
  ::mkdir(dir.c_str(), 0755);
  return sweepscan::testing::RemoveAtExit(dir);
}

bool Exists(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0;
}

std::string Read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

int CountEntries(const std::string& dir) {
  int n = 0;
  std::FILE* p = ::popen(("ls -A " + dir + " | wc -l").c_str(), "r");
  if (p != nullptr) {
    if (std::fscanf(p, "%d", &n) != 1) n = -1;
    ::pclose(p);
  }
  return n;
}

std::vector<CloudPoint> ManyPoints(size_t n) {
  std::vector<CloudPoint> pts(n);
  for (size_t i = 0; i < n; ++i) {
    pts[i].x = static_cast<float>(i);
    pts[i].time_ns = static_cast<int64_t>(i) * 1000;
  }
  return pts;
}

// Runs `body` in a child whose files may not grow beyond `limit` bytes;
// returns the child's exit code (SIGXFSZ ignored, so write() fails with EFBIG).
template <typename Body>
int WithFileSizeLimit(rlim_t limit, Body body) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::signal(SIGXFSZ, SIG_IGN);
    struct rlimit r = {limit, limit};
    ::setrlimit(RLIMIT_FSIZE, &r);
    ::_exit(body());
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 100 + WTERMSIG(status);
}

TEST(CheckedFileTest, WritesCompleteFilesAndReplacesAtomically) {
  const std::string dir = TempDir("ok");
  const std::string path = dir + "/a.txt";
  ASSERT_TRUE(WriteFileChecked(path, std::string(300000, 'a')).ok());
  EXPECT_EQ(Read(path).size(), 300000u);
  ASSERT_TRUE(WriteFileChecked(path, "short").ok());
  EXPECT_EQ(Read(path), "short");
  EXPECT_EQ(CountEntries(dir), 1);  // No temporary left.
}

// A symbolic link is written through, as an editor saves: the file it
// leads to (through a chain of links, relative or absolute) gets the new
// contents and every link stays a link; a link leading nowhere gets its
// file made where it points.
TEST(CheckedFileTest, ASymbolicLinkIsWrittenThroughAndStays) {
  const std::string dir = TempDir("links");
  ASSERT_EQ(::mkdir((dir + "/real").c_str(), 0755), 0);
  ASSERT_TRUE(WriteFileChecked(dir + "/real/site.sweepscan-project", "old").ok());
  ASSERT_EQ(::symlink("real/site.sweepscan-project", (dir + "/hop").c_str()), 0);
  ASSERT_EQ(::symlink((dir + "/hop").c_str(), (dir + "/site.sweepscan-project").c_str()), 0);
  ASSERT_TRUE(WriteFileChecked(dir + "/site.sweepscan-project", "new").ok());
  struct stat st;
  ASSERT_EQ(::lstat((dir + "/site.sweepscan-project").c_str(), &st), 0);
  EXPECT_TRUE(S_ISLNK(st.st_mode));
  ASSERT_EQ(::lstat((dir + "/hop").c_str(), &st), 0);
  EXPECT_TRUE(S_ISLNK(st.st_mode));
  EXPECT_EQ(Read(dir + "/real/site.sweepscan-project"), "new");
  EXPECT_EQ(CountEntries(dir + "/real"), 1);  // the temporary was beside the file, and went
  ASSERT_EQ(::symlink("real/later.txt", (dir + "/dangling").c_str()), 0);
  ASSERT_TRUE(WriteFileChecked(dir + "/dangling", "made").ok());
  EXPECT_EQ(Read(dir + "/real/later.txt"), "made");
  ASSERT_EQ(::lstat((dir + "/dangling").c_str(), &st), 0);
  EXPECT_TRUE(S_ISLNK(st.st_mode));
  // A loop is the kernel's error, not a hang.
  ASSERT_EQ(::symlink("loop-b", (dir + "/loop-a").c_str()), 0);
  ASSERT_EQ(::symlink("loop-a", (dir + "/loop-b").c_str()), 0);
  const Status loop = WriteFileChecked(dir + "/loop-a", "x");
  ASSERT_FALSE(loop.ok());
  EXPECT_NE(loop.message().find("loop-a: cannot follow its symbolic links: Too many levels"),
            std::string::npos)
      << loop.message();
  ASSERT_EQ(::lstat((dir + "/loop-a").c_str(), &st), 0);
  EXPECT_TRUE(S_ISLNK(st.st_mode));
}

// Asked before the work: the answer writing would give, and nothing left
// behind either way (the previous file untouched).
TEST(CheckedFileTest, CheckCanWriteAnswersAsWritingWouldAndLeavesNothing) {
  const std::string dir = TempDir("probe");
  ASSERT_TRUE(WriteFileChecked(dir + "/old.las", "old").ok());
  EXPECT_TRUE(CheckCanWrite(dir + "/old.las").ok());
  EXPECT_TRUE(CheckCanWrite(dir + "/new.las").ok());
  EXPECT_EQ(Read(dir + "/old.las"), "old");
  EXPECT_FALSE(Exists(dir + "/new.las"));
  EXPECT_EQ(CountEntries(dir), 1);
  const Status missing = CheckCanWrite(dir + "/missing/x.las");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("cannot create x.las.tmp-"), std::string::npos)
      << missing.message();
  EXPECT_NE(missing.message().find("No such file or directory"), std::string::npos)
      << missing.message();
  const Status folder = CheckCanWrite(dir);
  ASSERT_FALSE(folder.ok());
  EXPECT_NE(folder.message().find("is a folder"), std::string::npos) << folder.message();
}

TEST(CheckedFileTest, AFailedWriteLeavesTheOldFileAndNoTemporary) {
  const std::string dir = TempDir("efbig");
  const std::string path = dir + "/out.txt";
  ASSERT_TRUE(WriteFileChecked(path, "old content").ok());
  const int code = WithFileSizeLimit(100000, [&] {
    const Status s = WriteFileChecked(path, std::string(1 << 20, 'x'));
    if (s.ok()) return 1;
    // One line naming the file and the OS error.
    if (s.message().find(path + ": write failed: File too large") != 0) return 2;
    return 0;
  });
  EXPECT_EQ(code, 0);
  EXPECT_EQ(Read(path), "old content");
  EXPECT_EQ(CountEntries(dir), 1);
}

TEST(CheckedFileTest, CloudOnAFullFileSystemIsAnErrorNotAShortFile) {
  // Before: PCL's PLY writer returned success after the failed write, leaving
  // a short PLY whose header promised every vertex; its PCD writer threw.
  const std::string dir = TempDir("cloud");
  for (const char* name : {"/c.ply", "/c.pcd"}) {
    const std::string path = dir + name;
    const int code = WithFileSizeLimit(200000, [&] {
      const Status s = SaveCloud(path, ManyPoints(100000));
      if (s.ok()) return 1;
      return s.message().find("File too large") != std::string::npos ? 0 : 2;
    });
    EXPECT_EQ(code, 0) << name;
    EXPECT_FALSE(Exists(path)) << name;
  }
  EXPECT_EQ(CountEntries(dir), 0);
}

TEST(CheckedFileTest, FullTmpfsGivesNoSpaceLeftOnDevice) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to mount a small tmpfs";
  const std::string dir = TempDir("tmpfs");
  if (::mount("tmpfs", dir.c_str(), "tmpfs", 0, "size=64k") != 0) {
    GTEST_SKIP() << "cannot mount tmpfs here";
  }
  const Status s = SaveCloud(dir + "/full.ply", ManyPoints(100000));
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find(dir + "/full.ply: write failed: No space left on device"),
            std::string::npos)
      << s.message();
  EXPECT_EQ(CountEntries(dir), 0);
  const Status t = WriteFileChecked(dir + "/meta.json", std::string(1 << 20, ' '));
  EXPECT_FALSE(t.ok());
  EXPECT_EQ(CountEntries(dir), 0);
  ::umount(dir.c_str());
}

TEST(CheckedFileTest, StaleTemporariesOfDeadProcessesAreRemoved) {
  const std::string dir = TempDir("stale");
  const std::string path = dir + "/cloud.ply";
  const pid_t dead = ::fork();
  if (dead == 0) ::_exit(0);
  ::waitpid(dead, nullptr, 0);  // Reaped: no process has this PID now.
  const std::string stale = path + ".tmp-" + std::to_string(dead);
  const std::string alive = path + ".tmp-1";  // init: running.
  const std::string other = dir + "/other.ply.tmp-" + std::to_string(dead);
  for (const std::string& p : {stale, alive, other}) std::ofstream(p) << "partial";
  ASSERT_TRUE(WriteFileChecked(path, "new").ok());
  EXPECT_FALSE(Exists(stale));
  EXPECT_TRUE(Exists(alive));   // Its writer may still be running.
  EXPECT_TRUE(Exists(other));   // Another file's temporary is not ours to judge.
  EXPECT_TRUE(IsTemporaryFileName("cloud.ply.tmp-123"));
  EXPECT_FALSE(IsTemporaryFileName("cloud.ply"));
  EXPECT_FALSE(IsTemporaryFileName("x.tmp-"));
}

// Names of up to 255 bytes, the most a file name may have, are written
// (their temporary cut short: a 252-byte name failed, "File name too
// long", on its ".tmp-PID"), and a dead writer's cut temporary is found.
TEST(CheckedFileTest, TheLongestNamesAreWrittenAndTheirStaleTemporariesFound) {
  const std::string dir = TempDir("long");
  // 250 bytes of "é" (two bytes each) behind an ASCII byte or not: the
  // cut of one falls inside a character, and moves back before it.
  std::string name;
  for (int i = 0; i < 125; ++i) name += "\xc3\xa9";
  for (const std::string& n :
       {"x" + name + ".ply", name + ".p", std::string(252, 'a'), std::string(240, 'b')}) {
    SCOPED_TRACE(n.size());
    const std::string path = dir + "/" + n;
    const std::string tmp = TemporaryPathFor(path);
    const std::string tmp_name = tmp.substr(dir.size() + 1);
    EXPECT_LE(tmp_name.size(), 255u);
    EXPECT_TRUE(IsTemporaryFileName(tmp_name));
    const size_t suffix = tmp_name.rfind(".tmp-" + std::to_string(::getpid()));
    ASSERT_NE(suffix, std::string::npos);
    // A cut name ends in "~" and its hash; what is kept before them is not
    // half an "é".
    const size_t tilde = tmp_name.rfind('~', suffix);
    const size_t kept = tilde == std::string::npos ? suffix : tilde;
    EXPECT_EQ(tilde == std::string::npos, n.size() <= 240u);
    EXPECT_NE(static_cast<unsigned char>(tmp_name[kept - 1]), 0xC3u);
    ASSERT_TRUE(WriteFileChecked(path, "whole").ok());
    EXPECT_EQ(Read(path), "whole");
  }
  EXPECT_EQ(CountEntries(dir), 4);  // No temporary left.
  // Two names alike in their first 240 bytes, written at once: each its
  // own temporary (cut alike, they shared one).
  const std::string first = dir + "/" + std::string(250, 'c') + "1",
                    second = dir + "/" + std::string(250, 'c') + "2";
  EXPECT_NE(TemporaryPathFor(first), TemporaryPathFor(second));
  CheckedFileWriter a, b;
  ASSERT_TRUE(a.Open(first).ok());
  ASSERT_TRUE(b.Open(second).ok());
  ASSERT_TRUE(a.Write("first").ok() && b.Write("second").ok());
  ASSERT_TRUE(a.Commit().ok() && b.Commit().ok());
  EXPECT_EQ(Read(first), "first");
  EXPECT_EQ(Read(second), "second");
  ASSERT_TRUE(::unlink(first.c_str()) == 0 && ::unlink(second.c_str()) == 0);
  // A killed writer's temporary of the 252-byte name, found as stale.
  const pid_t dead = ::fork();
  if (dead == 0) ::_exit(0);
  ::waitpid(dead, nullptr, 0);
  const std::string path = dir + "/" + std::string(252, 'a');
  const std::string ours = TemporaryPathFor(path);
  const std::string stale = ours.substr(0, ours.rfind('-') + 1) + std::to_string(dead);
  std::ofstream(stale) << "partial";
  ASSERT_TRUE(Exists(stale));
  EXPECT_EQ(RemoveStaleTemporaries(path), 1);
  EXPECT_FALSE(Exists(stale));
}

TEST(CheckedFileTest, AFolderWhereAFileIsExpectedIsAClearError) {
  const std::string dir = TempDir("folder");
  const Status w = WriteFileChecked(dir, "x");
  EXPECT_FALSE(w.ok());
  EXPECT_NE(w.message().find("is a folder"), std::string::npos) << w.message();
  const Status r = CheckRegularFile(dir);
  EXPECT_NE(r.message().find("is a folder"), std::string::npos) << r.message();
  const Status m = CheckRegularFile(dir + "/missing");
  EXPECT_NE(m.message().find("No such file or directory"), std::string::npos) << m.message();
  const Status c = WriteFileChecked("/nonexistent-dir/x.json", "x");
  EXPECT_NE(c.message().find("/nonexistent-dir/x.json: cannot create"), std::string::npos)
      << c.message();
}

}  // namespace
}  // namespace sweepscan
