// # implicit: files
//
// The one way files are read and written, below every module that touches
// them (images, grids, meshes, scenes, the front ends): a file is read whole
// through a read-only mapping, and written whole or not at all, under a
// temporary name unique to the process and the call, renamed over the target
// only once every byte is out. Errors throw io_error "file: problem (reason)".
// Also the extension that picks a format, and the check that an output can be
// written before a long render starts.
#pragma once

#include <cstddef>
#include <cstdio>
#include <string>

namespace implicit {

// -----------------------------------------------------------------------------
// NAMES
// -----------------------------------------------------------------------------

// Lower-case extension with its dot (".png"), taken after the last '.' of
// the file name (not of a folder); "" when there is none.
std::string path_extension(const std::string& filename);

// The temporary file for an atomic write of `filename`:
// ".<name>.tmp<pid>.<unique>" in the same folder, so that the final rename
// stays on one file system; the process id and a unique suffix keep two
// writers (processes or threads) of the same target apart.
std::string temporary_path(const std::string& filename);

// Throw io_error "filename: ..." unless the folder of `filename` exists, is
// a folder and is writable (checked before rendering, not after).
void check_output_directory(const std::string& filename);

// -----------------------------------------------------------------------------
// READING
// -----------------------------------------------------------------------------

// A whole file mapped read-only; move-only owner of the mapping. Throws
// io_error "filename: cannot open (reason)" for a missing or unreadable
// file, a folder or anything but a regular file, and "filename: file is
// empty" (no format we read has an empty file).
struct mapped_file {
  const char* data = nullptr;
  size_t      size = 0;

  explicit mapped_file(const std::string& filename);
  ~mapped_file();
  mapped_file(mapped_file&& other) noexcept;
  mapped_file& operator=(mapped_file&&)      = delete;
  mapped_file(const mapped_file&)            = delete;
  mapped_file& operator=(const mapped_file&) = delete;
};

// The bytes of a whole file (through mapped_file), for parsers that keep
// them or need a terminated string.
std::string read_file(const std::string& filename);

// -----------------------------------------------------------------------------
// WRITING
// -----------------------------------------------------------------------------

// A file being written: a new temporary (temporary_path(), created
// exclusively) that commit_file() renames to `filename`; destroyed
// uncommitted (an error, an exception), the temporary is removed, and the
// target keeps whatever it held. Writers that take a FILE* write to `file`;
// a library that can only write by name (OpenVDB) writes the whole file to
// `temporary` itself, then commit_file(). Move-only owner of the FILE*.
struct output_file {
  std::string filename  = "";
  std::string temporary = "";
  FILE*       file      = nullptr;

  explicit output_file(const std::string& filename);
  ~output_file();
  output_file(const output_file&)            = delete;
  output_file& operator=(const output_file&) = delete;
};

// Append bytes; throws io_error "filename: cannot write (reason)".
void write_bytes(output_file& out, const void* data, size_t size);
// Flush, close and rename to the final name; throws io_error "filename:
// cannot write (reason)" (a full disk shows up here) after removing the
// temporary.
void commit_file(output_file& out);

// Write a whole file at once, atomically.
void write_file(const std::string& filename, const void* data, size_t size);
void write_file(const std::string& filename, const std::string& data);

}  // namespace implicit
