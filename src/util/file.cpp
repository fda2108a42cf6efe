// # implicit: files (implementation)

#include "file.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <random>

#include "error.h"

namespace implicit {

// -----------------------------------------------------------------------------
// NAMES
// -----------------------------------------------------------------------------

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

// -----------------------------------------------------------------------------
// READING
// -----------------------------------------------------------------------------

// "cannot open (reason)" for errno `code`.
[[noreturn]] static void throw_cannot_open(
    const std::string& filename, int code) {
  throw_io_error(
      filename, "cannot open (" + std::string{std::strerror(code)} + ")");
}

mapped_file::mapped_file(const std::string& filename) {
  auto fd = ::open(filename.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw_cannot_open(filename, errno);
  struct stat info;
  if (::fstat(fd, &info) != 0) {
    auto code = errno;
    ::close(fd);
    throw_cannot_open(filename, code);
  }
  if (!S_ISREG(info.st_mode)) {
    ::close(fd);
    if (S_ISDIR(info.st_mode)) throw_cannot_open(filename, EISDIR);
    throw_io_error(filename, "cannot open (not a regular file)");
  }
  if (info.st_size == 0) {
    ::close(fd);
    throw_io_error(filename, "file is empty");
  }
  auto mapping =
      ::mmap(nullptr, (size_t)info.st_size, PROT_READ, MAP_PRIVATE, fd, 0);
  auto code = errno;
  ::close(fd);  // the mapping keeps the file
  if (mapping == MAP_FAILED)
    throw_io_error(
        filename, "cannot read (" + std::string{std::strerror(code)} + ")");
  data = (const char*)mapping;
  size = (size_t)info.st_size;
}

mapped_file::~mapped_file() {
  if (data) ::munmap((void*)data, size);
}

mapped_file::mapped_file(mapped_file&& other) noexcept
    : data{other.data}, size{other.size} {
  other.data = nullptr;
  other.size = 0;
}

std::string read_file(const std::string& filename) {
  auto file = mapped_file{filename};
  return std::string(file.data, file.size);
}

// -----------------------------------------------------------------------------
// WRITING
// -----------------------------------------------------------------------------

// "cannot write (reason)" for errno `code`.
[[noreturn]] static void throw_cannot_write(
    const std::string& filename, int code) {
  throw_io_error(filename,
      "cannot write (" + std::string{code ? std::strerror(code) : "I/O error"} +
          ")");
}

output_file::output_file(const std::string& name)
    : filename{name}, temporary{temporary_path(name)} {
  // "x": created exclusively, never an existing file.
  file = std::fopen(temporary.c_str(), "wbx");
  if (!file) throw_cannot_write(filename, errno);
}

output_file::~output_file() {
  if (!file) return;
  std::fclose(file);
  std::remove(temporary.c_str());
}

void write_bytes(output_file& out, const void* data, size_t size) {
  errno = 0;
  if (size != 0 && std::fwrite(data, 1, size, out.file) != size)
    throw_cannot_write(out.filename, errno);
}

void commit_file(output_file& out) {
  errno     = 0;
  auto ok   = std::fflush(out.file) == 0 && !std::ferror(out.file);
  auto code = errno;
  ok        = std::fclose(out.file) == 0 && ok;
  if (!code) code = errno;
  out.file = nullptr;
  if (ok && std::rename(out.temporary.c_str(), out.filename.c_str()) == 0)
    return;
  if (!code) code = errno;
  std::remove(out.temporary.c_str());
  throw_cannot_write(out.filename, code);
}

void write_file(const std::string& filename, const void* data, size_t size) {
  auto out = output_file{filename};
  write_bytes(out, data, size);
  commit_file(out);
}

void write_file(const std::string& filename, const std::string& data) {
  write_file(filename, data.data(), data.size());
}

}  // namespace implicit
