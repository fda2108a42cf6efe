// # implicit: errors
//
// Setup code (loaders, CLI, make_*) throws io_error; the message already names
// the file and the place: `file[:line]: array[i] ("name").key: problem`.
#pragma once

#include <stdexcept>
#include <string>

namespace implicit {

struct io_error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Throw an io_error "filename: message".
[[noreturn]] inline void throw_io_error(
    const std::string& filename, const std::string& message) {
  throw io_error(filename + ": " + message);
}

}  // namespace implicit
