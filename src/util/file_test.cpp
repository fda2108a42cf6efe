// Tests of the file layer: the one reader and the one atomic writer.

#include "file.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "error.h"

using namespace implicit;
namespace fs = std::filesystem;

namespace {

// A fresh folder for one test.
fs::path file_test_dir(const std::string& name) {
  auto dir = fs::path{IMPLICIT_BINARY_DIR} / "test_outputs" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// The message of the io_error `call` throws, or "".
template <typename Call>
std::string error_of(const Call& call) {
  try {
    call();
  } catch (const io_error& error) { return error.what(); }
  return "";
}

// Names in a folder, sorted.
std::vector<std::string> folder_names(const fs::path& dir) {
  auto names = std::vector<std::string>{};
  for (auto& entry : fs::directory_iterator(dir))
    names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace

TEST_CASE("file layer: the reader names the file and the reason") {
  auto dir  = file_test_dir("file_read");
  auto name = (dir / "data.bin").string();
  write_file(name, std::string("a\0b", 3));
  CHECK(read_file(name) == std::string("a\0b", 3));
  {
    auto file = mapped_file{name};
    CHECK(file.size == 3);
    CHECK(file.data[2] == 'b');
    auto moved = mapped_file{std::move(file)};
    CHECK(file.data == nullptr);
    CHECK(moved.size == 3);
  }
  auto missing = (dir / "missing.bin").string();
  CHECK(error_of([&] { read_file(missing); }) ==
        missing + ": cannot open (No such file or directory)");
  CHECK(error_of([&] { read_file(dir.string()); }) ==
        dir.string() + ": cannot open (Is a directory)");
  CHECK(error_of([&] { read_file("/dev/null"); }) ==
        "/dev/null: cannot open (not a regular file)");
  auto empty = (dir / "empty.bin").string();
  write_file(empty, "");
  CHECK(fs::exists(empty));
  CHECK(error_of([&] { read_file(empty); }) == empty + ": file is empty");
}

TEST_CASE("file layer: a file is written whole or not at all") {
  auto dir  = file_test_dir("file_write");
  auto name = (dir / "out.txt").string();
  write_file(name, "first");
  CHECK(read_file(name) == "first");
  write_file(name, "second, longer");
  CHECK(read_file(name) == "second, longer");
  // An uncommitted write (an error, an exception) leaves the old file and
  // no temporary.
  {
    auto out = output_file{name};
    write_bytes(out, "third", 5);
    CHECK(out.temporary.find(dir.string() + "/.out.txt.tmp") == 0);
    CHECK(fs::exists(out.temporary));
  }
  CHECK(read_file(name) == "second, longer");
  CHECK(folder_names(dir) == std::vector<std::string>{"out.txt"});
  // A rename that fails (a folder is in the way) removes the temporary.
  fs::create_directories(dir / "taken");
  auto taken = (dir / "taken").string();
  CHECK(error_of([&] {
    write_file(taken, "x");
  }).find(taken + ": cannot write (") == 0);
  CHECK(folder_names(dir) == std::vector<std::string>{"out.txt", "taken"});
  // A folder that does not exist.
  auto nowhere = (dir / "nowhere" / "x.txt").string();
  CHECK(error_of([&] { write_file(nowhere, "x"); }) ==
        nowhere + ": cannot write (No such file or directory)");
}

TEST_CASE("file layer: writers of one target never share a temporary") {
  auto dir  = file_test_dir("file_concurrent");
  auto name = (dir / "shared.dat").string();
  {
    // Two writers in one process at once: two temporaries.
    auto a = output_file{name};
    auto b = output_file{name};
    CHECK(a.temporary != b.temporary);
    write_bytes(a, "aaaa", 4);
    write_bytes(b, "bb", 2);
    commit_file(b);
    commit_file(a);
  }
  CHECK(read_file(name) == "aaaa");
  // Many threads: the file is always one writer's whole text.
  auto texts = std::vector<std::string>{};
  for (auto i = 0; i < 8; i++) texts.push_back(std::string(1000 + i, 'a' + i));
  auto threads = std::vector<std::thread>{};
  for (auto& text : texts)
    threads.emplace_back([&name, &text] {
      for (auto k = 0; k < 20; k++) write_file(name, text);
    });
  for (auto& thread : threads) thread.join();
  auto result = read_file(name);
  CHECK(std::find(texts.begin(), texts.end(), result) != texts.end());
  CHECK(folder_names(dir) == std::vector<std::string>{"shared.dat"});
}
