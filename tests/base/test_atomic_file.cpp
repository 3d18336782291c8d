// writeFileAtomic: the bytes land exactly, an existing file is replaced by a rename (never
// rewritten in place), no temporary is left beside the target, and failures name the path.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/atomic_file.hpp"
#include "test_support.hpp"

namespace ambler::base {
namespace {

namespace fs = std::filesystem;
using test::slurp;
using test::TempDir;

std::vector<fs::path> entries(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename());
  return out;
}

// The message of the runtime_error `write` throws (empty if it throws nothing or something else).
template <class F>
std::string runtimeErrorOf(F write) {
  try {
    write();
  } catch (const std::runtime_error& e) {
    return e.what();
  } catch (...) {
    return "";
  }
  return "";
}

TEST(WriteFileAtomic, WritesTheBytesExactly) {
  TempDir tmp;
  std::string bytes;
  for (int rep = 0; rep < 300; ++rep)
    for (int b = 0; b < 256; ++b) bytes.push_back(char(b));  // every byte value, NULs and CR/LF too
  const fs::path p = tmp.path() / "all_bytes.bin";
  writeFileAtomic(p, bytes);
  EXPECT_EQ(fs::file_size(p), bytes.size());
  EXPECT_EQ(slurp(p), bytes);
  const fs::path empty = tmp.path() / "empty.txt";
  writeFileAtomic(empty, "");
  ASSERT_TRUE(fs::exists(empty));
  EXPECT_EQ(fs::file_size(empty), 0u);
}

TEST(WriteFileAtomic, ReplacesAnExistingFileByRename) {
  TempDir tmp;
  const fs::path p = tmp.path() / "out.json";
  writeFileAtomic(p, "a longer first version of the file\n");
  // A hard link to the first version: a rename over `p` leaves the linked inode as it was, while
  // a rewrite in place (truncate and write) would change it too.
  const fs::path link = tmp.path() / "old_link";
  fs::create_hard_link(p, link);
  writeFileAtomic(p, "v2");
  EXPECT_EQ(slurp(p), "v2");  // shorter: nothing of the old content is left behind
  EXPECT_EQ(slurp(link), "a longer first version of the file\n");
  EXPECT_EQ(fs::hard_link_count(p), 1u);
}

TEST(WriteFileAtomic, LeavesNoTemporaryFile) {
  TempDir tmp;
  writeFileAtomic(tmp.path() / "a.txt", "one");
  writeFileAtomic(tmp.path() / "a.txt", "two");
  writeFileAtomic(tmp.path() / "b.txt", "three");
  auto names = entries(tmp.path());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<fs::path>{"a.txt", "b.txt"}));
}

TEST(WriteFileAtomic, ThrowsNamingThePathWhenTheDirectoryCannotBeWritten) {
  TempDir tmp;
  // A directory that does not exist.
  const fs::path missing = tmp.path() / "no_such_dir" / "f.txt";
  const std::string m1 = runtimeErrorOf([&] { writeFileAtomic(missing, "x"); });
  EXPECT_NE(m1.find(missing.string()), std::string::npos) << m1;
  // A "directory" that is a regular file.
  const fs::path file = tmp.path() / "plain";
  std::ofstream(file) << "not a directory";
  const fs::path under_file = file / "f.txt";
  const std::string m2 = runtimeErrorOf([&] { writeFileAtomic(under_file, "x"); });
  EXPECT_NE(m2.find(under_file.string()), std::string::npos) << m2;
  // A directory without write permission (permissions do not bind root, so only as another user).
  if (::geteuid() != 0) {
    const fs::path ro = tmp.path() / "read_only";
    fs::create_directory(ro);
    fs::permissions(ro, fs::perms::owner_read | fs::perms::owner_exec);
    const std::string m3 = runtimeErrorOf([&] { writeFileAtomic(ro / "f.txt", "x"); });
    fs::permissions(ro, fs::perms::owner_all);
    EXPECT_NE(m3.find((ro / "f.txt").string()), std::string::npos) << m3;
  }
  // The target is a directory: the temporary is written, the rename fails; it throws naming the
  // path, removes the temporary and leaves the directory alone.
  const fs::path dir_target = tmp.path() / "taken";
  fs::create_directory(dir_target);
  const std::string m4 = runtimeErrorOf([&] { writeFileAtomic(dir_target, "x"); });
  EXPECT_NE(m4.find(dir_target.string()), std::string::npos) << m4;
  EXPECT_TRUE(fs::is_directory(dir_target));
  auto names = entries(tmp.path());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<fs::path>{"plain", "taken"}));
}

}  // namespace
}  // namespace ambler::base
