// # implicit: fuzz harness helpers
//
// Every harness feeds the fuzzer's bytes to one loader. A malformed input
// must end as an io_error naming the file; any other exception (bad_alloc
// included) escapes the harness, std::terminate aborts and libFuzzer records
// the input as a crash.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "../src/util/error.h"

namespace implicit {

// A temporary file holding the input, for loaders that take a file name
// (they map the file); removed when it goes out of scope. One name per
// process, so that parallel fuzzers do not share it.
struct fuzz_input_file {
  std::string filename = "";

  fuzz_input_file(const uint8_t* data, size_t size, const char* extension) {
    auto directory = std::getenv("TMPDIR");
    filename = std::string(directory ? directory : "/tmp") + "/implicit_fuzz_" +
               std::to_string((long long)getpid()) + extension;
    auto file = std::fopen(filename.c_str(), "wb");
    if (!file) std::abort();
    if (size != 0 && std::fwrite(data, 1, size, file) != size) std::abort();
    if (std::fclose(file) != 0) std::abort();
  }
  ~fuzz_input_file() { std::remove(filename.c_str()); }
  fuzz_input_file(const fuzz_input_file&)            = delete;
  fuzz_input_file& operator=(const fuzz_input_file&) = delete;
};

}  // namespace implicit
