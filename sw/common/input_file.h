#pragma once
/// Files a run reads, kept apart from the files it writes ("inputs are sacred"). Every reader of
/// a user's file (the configuration, the component library, the model, the dataset files, CSV
/// inputs, journals) registers the file here when it opens it, under its role; the output layer
/// (sw/common/output_file.h) and the journals refuse to write any file registered here, compared
/// by device and inode however it is named, so no run can truncate, overwrite or append to a
/// file it reads.
#include <cstddef>
#include <iosfwd>
#include <optional>
#include <string>

namespace xbarsim {

/// A file this run reads.
struct InputFile {
  std::string path;  ///< as it was registered
  std::string role;  ///< e.g. "the model", "the configuration file"
};

/// Registers `path` as read by this run in `role`. Nothing for a path that does not exist or
/// is not a regular file (a terminal or a pipe is not destroyed by writing to it).
void register_input(const std::string& path, const std::string& role);

/// The registered input that `path` names (the same device and inode), if any.
std::optional<InputFile> registered_input(const std::string& path);

/// Whether `a` and `b` name one existing file (device and inode).
bool same_file(const std::string& a, const std::string& b);

/// What a reader does as it opens a user's file `path` (its `role` names it in messages):
/// InputError when it is a directory, and register_input.
void open_as_input(const std::string& path, const std::string& role);

/// The whole of the input file `path` (its `role` names it in messages), registered as read:
/// InputError when it cannot be opened, is a directory, cannot be read to its end, or holds
/// more than `max_bytes` (a device such as /dev/zero never ends).
std::string read_input_file(const std::string& path, const std::string& role, size_t max_bytes);

/// What read_line found.
enum class LineRead {
  Line,        ///< a line and its '\n'
  Unfinished,  ///< the last line, without '\n' (a file cut short, or one that does not end in one)
  TooLong,     ///< more than the bound before any '\n' (`line` holds the first bytes)
  End          ///< nothing left
};
/// The next line of `in` into `line` (without '\n'), reading at most `max_bytes` + 1 bytes of
/// it: a device such as /dev/zero has no line end, and std::getline would grow without bound.
LineRead read_line(std::istream& in, std::string& line, size_t max_bytes);

/// The largest YAML file (configuration, component library) read: far above any real one.
constexpr size_t kMaxYamlBytes = size_t{16} << 20;

}  // namespace xbarsim
