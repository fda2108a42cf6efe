// # implicit: file names and safe writes
//
// The helpers every loader, saver and front end shares: the extension that
// picks a format, the temporary name of an atomic write, and the check that
// an output can be written before a long render starts.
#pragma once

#include <string>

namespace implicit {

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

}  // namespace implicit
