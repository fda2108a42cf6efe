// # implicit: file names and safe writes (implementation)

#include "file.h"

#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <random>

#include "error.h"

namespace implicit {

std::string path_extension(const std::string& filename) {
  auto slash = filename.find_last_of('/');
  auto dot   = filename.rfind('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash))
    return "";
  auto ext = filename.substr(dot);
  for (auto& c : ext) c = (char)std::tolower((unsigned char)c);
  return ext;
}

std::string temporary_path(const std::string& filename) {
  auto path   = std::filesystem::path(filename);
  auto device = std::random_device{};
  auto unique = ((uint64_t)device() << 32) | (uint64_t)device();
  char suffix[17];
  std::snprintf(suffix, sizeof(suffix), "%016llx", (unsigned long long)unique);
  auto name = "." + path.filename().string() + ".tmp" +
              std::to_string((long long)getpid()) + "." + suffix;
  return (path.parent_path() / name).string();
}

void check_output_directory(const std::string& filename) {
  auto parent = std::filesystem::path(filename).parent_path();
  auto folder = parent.empty() ? std::filesystem::path{"."} : parent;
  auto error  = std::error_code{};
  if (!std::filesystem::is_directory(folder, error))
    throw_io_error(filename, "cannot write: folder " + folder.string() +
                                 " does not exist or is not a folder");
  if (::access(folder.c_str(), W_OK) != 0)
    throw_io_error(filename, "cannot write: folder " + folder.string() +
                                 " is not writable (" + std::strerror(errno) +
                                 ")");
}

}  // namespace implicit
