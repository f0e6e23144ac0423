// Save requests: which paths are written, and that a failed write never reports success.
#include <gtest/gtest.h>

#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <string>

#include "avsp_terrain/output_file.hpp"

namespace at = avsp::terrain;

namespace
{
/// Every entry below `dir`, recursively, with its size: the state a refusal must not change.
std::set<std::string> listing(const std::string& dir)
{
  std::set<std::string> out;
  DIR* d = opendir(dir.c_str());
  if (d == nullptr)
    return out;
  while (dirent* e = readdir(d))
  {
    const std::string name = e->d_name;
    if (name == "." || name == "..")
      continue;
    const std::string path = dir + "/" + name;
    struct stat st;
    lstat(path.c_str(), &st);
    out.insert(path + " " + std::to_string(st.st_size));
    if (S_ISDIR(st.st_mode))
      for (const std::string& s : listing(path))
        out.insert(s);
  }
  closedir(d);
  return out;
}

std::string slurp(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class OutputFile : public ::testing::Test
{
protected:
  void SetUp() override
  {
    char tmpl[] = "/tmp/avsp_test_output_file_XXXXXX";
    ASSERT_NE(mkdtemp(tmpl), nullptr);
    root = tmpl;
    folder.directory = at::prepareOutputFolder(root + "/out/maps");
    ASSERT_EQ(folder.directory, root + "/out/maps");
    ASSERT_EQ(mkdir((folder.directory + "/sub").c_str(), 0775), 0);
    ASSERT_EQ(mkdir((root + "/elsewhere").c_str(), 0775), 0);
    ASSERT_EQ(symlink("/dev/full", (folder.directory + "/full.bt").c_str()), 0);
    ASSERT_EQ(symlink((root + "/elsewhere").c_str(), (folder.directory + "/escape").c_str()), 0);
    ASSERT_EQ(mkfifo((folder.directory + "/pipe.bt").c_str(), 0664), 0);
    std::ofstream(folder.directory + "/old.bt") << "good map";
  }
  void TearDown() override { ASSERT_EQ(std::system(("rm -rf '" + root + "'").c_str()), 0); }

  /// The refusal's message, or "" if the request was accepted.
  std::string refusal(const std::string& request, const at::OutputFolder& f)
  {
    try
    {
      at::resolveOutputPath(request, f);
      return "";
    }
    catch (const at::OutputFileError& e)
    {
      return e.what();
    }
  }

  std::string root;
  at::OutputFolder folder;
};
}  // namespace

TEST_F(OutputFile, RelativeAndInsidePathsResolveInTheFolder)
{
  EXPECT_EQ(at::resolveOutputPath("a.bt", folder), folder.directory + "/a.bt");
  EXPECT_EQ(at::resolveOutputPath("sub//b.tif", folder), folder.directory + "/sub/b.tif");
  EXPECT_EQ(at::resolveOutputPath(folder.directory + "/old.bt", folder), folder.directory + "/old.bt");
  // Outside only when the operator allows it.
  EXPECT_NE(refusal(root + "/elsewhere/c.bt", folder).find("outside the output folder"), std::string::npos);
  at::OutputFolder open = folder;
  open.allow_absolute_paths = true;
  EXPECT_EQ(at::resolveOutputPath(root + "/elsewhere/c.bt", open), root + "/elsewhere/c.bt");
}

TEST_F(OutputFile, RefusalsNameTheRequestAndTheReason)
{
  const auto expectRefused = [&](const std::string& request, const std::string& reason) {
    const std::string m = refusal(request, folder);
    EXPECT_NE(m.find(reason), std::string::npos) << "request '" << request << "' gave: '" << m << "'";
    EXPECT_EQ(m.rfind("path '", 0), 0u) << m;
  };
  expectRefused("", "empty");
  expectRefused(std::string("a\0b.bt", 6), "control character");
  expectRefused(folder.directory + std::string("/x\0.bt", 6), "control character");
  expectRefused("a\nb.bt", "control character");
  expectRefused("a\x7f.bt", "control character");
  expectRefused("../x.bt", "'..'");
  expectRefused("sub/../../x.bt", "'..'");
  expectRefused("./x.bt", "'.'");
  expectRefused("sub/", "folder, not a file");
  expectRefused("missing/x.bt", "does not exist");
  expectRefused("full.bt", "symbolic link");
  expectRefused("pipe.bt", "a pipe");
  expectRefused("sub", "a directory");
  expectRefused("escape/x.bt", "outside the output folder");
  expectRefused("/etc/passwd", "outside the output folder");
  expectRefused(std::string(5000, 'a'), "longer than");
  // The NUL case is shown, not cut: the message names the whole request.
  EXPECT_NE(refusal(std::string("a\0b.bt", 6), folder).find("a\\x00b.bt"), std::string::npos);
}

TEST_F(OutputFile, OutputFolderMustBeAbsoluteAndADirectory)
{
  EXPECT_THROW(at::prepareOutputFolder("relative/maps"), at::OutputFileError);
  EXPECT_THROW(at::prepareOutputFolder(folder.directory + "/old.bt"), at::OutputFileError);
  EXPECT_THROW(at::prepareOutputFolder(root + "/../x"), at::OutputFileError);
  EXPECT_EQ(at::prepareOutputFolder(root + "/new//deep/"), root + "/new/deep");
  struct stat st;
  ASSERT_EQ(stat((root + "/new/deep").c_str(), &st), 0);
  EXPECT_TRUE(S_ISDIR(st.st_mode));
}

TEST_F(OutputFile, AFullDeviceIsAFailedWriteNotASuccess)
{
  try
  {
    at::writeBytes("/dev/full", std::string(100000, 'x'));
    FAIL() << "writing to /dev/full succeeded";
  }
  catch (const at::OutputFileError& e)
  {
    EXPECT_NE(std::string(e.what()).find("No space left on device"), std::string::npos) << e.what();
  }
}

TEST_F(OutputFile, AFailedWriteLeavesTheEarlierFileAndNoPartialOne)
{
  const std::set<std::string> before = listing(root);
  const std::string path = at::resolveOutputPath("old.bt", folder);
  EXPECT_THROW(at::writeThroughTemporary(path,
                                         [](const std::string& tmp) {
                                           at::writeBytes(tmp, "half a m");
                                           throw at::OutputFileError("disk went away");
                                         }),
               at::OutputFileError);
  EXPECT_EQ(slurp(path), "good map");
  EXPECT_EQ(listing(root), before);

  at::writeThroughTemporary(path, [](const std::string& tmp) { at::writeBytes(tmp, "new map"); });
  EXPECT_EQ(slurp(path), "new map");
  std::set<std::string> after = listing(root);
  after.erase(path + " 7");
  std::set<std::string> expected = before;
  expected.erase(path + " 8");
  EXPECT_EQ(after, expected) << "a temporary was left behind";
}

/// 5000 seeded requests built from the pieces attackers and typos use: every one is either
/// refused with a message and nothing changed, or resolves inside the folder and then writes
/// exactly there.
TEST_F(OutputFile, SeededFuzzOfRequests)
{
  const std::vector<std::string> pieces = {
    "a",
    "map.bt",
    "x.tif",
    "/",
    "//",
    ".",
    "..",
    "sub",
    "escape",
    "full.bt",
    "pipe.bt",
    "old.bt",
    "missing",
    std::string(1, '\0'),
    "\n",
    "\t",
    "\x7f",
    "\x1b[2J",
    "\xc3\xa9",
    " ",
    "~",
    "$HOME",
    "*",
    "-rf",
    root,
    folder.directory,
    "/etc",
    "/dev/full",
    "/proc/self/mem",
    std::string(300, 'n'),
  };
  std::mt19937 rng(20261202);
  std::uniform_int_distribution<std::size_t> pick(0, pieces.size() - 1);
  std::uniform_int_distribution<int> count(1, 6);
  int accepted = 0, refused = 0;
  for (int k = 0; k < 5000; ++k)
  {
    std::string request;
    for (int n = count(rng); n > 0; --n)
      request += pieces[pick(rng)];
    const std::set<std::string> before = listing(root);
    std::string path;
    try
    {
      path = at::resolveOutputPath(request, folder);
    }
    catch (const at::OutputFileError& e)
    {
      ++refused;
      ASSERT_EQ(std::string(e.what()).rfind("path '", 0), 0u) << e.what();
      ASSERT_EQ(listing(root), before) << "a refusal changed the folder";
      continue;
    }
    ++accepted;
    ASSERT_EQ(path.rfind(folder.directory + "/", 0), 0u) << "request '" << request << "' -> " << path;
    ASSERT_EQ(path.find("/../"), std::string::npos) << path;
    for (unsigned char c : path)
      ASSERT_FALSE(c < 0x20 || c == 0x7f) << path;
    at::writeThroughTemporary(path, [&](const std::string& tmp) { at::writeBytes(tmp, request); });
    ASSERT_EQ(slurp(path), request) << path;
    if (path != folder.directory + "/old.bt")
      std::remove(path.c_str());
    else
      std::ofstream(path) << "good map";
  }
  // Both branches ran many times: the generator is not degenerate.
  EXPECT_GT(accepted, 100);
  EXPECT_GT(refused, 1000);
}
