#pragma once
/// Output files named on the command line, handled in one place:
///  - check_output_path() validates a path before any work is done (not empty, not a
///    directory, its folder exists and a file can be created there under that name, and it is
///    not a file the run reads: one of `inputs`, or any file registered by a reader,
///    sw/common/input_file.h);
///  - OutputFile writes to a temporary file beside the target and renames it over the target
///    on commit(), so a reader never sees half a file and a failed run leaves the old file;
///    special files (a terminal, /dev/null, /dev/full, a pipe) are written in place; it, too,
///    refuses a file the run reads (registered by then), at opening and again at commit;
///  - every write, flush and close is checked: a full disk is an InputError naming the file;
///  - a temporary file is removed also when the process is ended by SIGTERM, SIGHUP or SIGINT
///    (where their handling is still the default: Python keeps its own SIGINT handler).
#include <fstream>
#include <string>
#include <vector>

namespace xbarsim {

/// Throws InputError naming `what` (e.g. "--json") and the path when `path` cannot be
/// written or created, is a directory, or is the same file as one of `inputs` (paths that do
/// not exist are ignored there) or as a file the run reads (register_input), naming its role.
void check_output_path(const std::string& path, const std::string& what, const std::vector<std::string>& inputs = {});

/// Throws InputError when `path` is a file this run reads (register_input): `what` (e.g.
/// "--json", "the journal") names the output, the message the input's role and that it will
/// not `verb` ("overwrite", "append to") it.
void refuse_input(const std::string& path, const std::string& what, const std::string& verb = "overwrite");

class OutputFile {
 public:
  /// Opens the temporary file (or the special file itself); throws InputError when it cannot,
  /// or when `path` is a file the run reads.
  explicit OutputFile(std::string path);
  /// Without commit() the temporary file is removed and the target left as it was.
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  std::ostream& stream() { return out_; }
  /// Flushes, closes and renames onto the target; throws InputError on any failure.
  void commit();
  const std::string& path() const { return path_; }

 private:
  std::string path_, target_, tmp_;  ///< as given; the file it names (links resolved); the temporary file
  std::ofstream out_;
  bool committed_ = false;
  int slot_ = -1;  ///< the temporary file's slot for removal on a signal
};

/// An output that another library writes under a name it is given (SystemC's VCD trace): the
/// library writes `staged()`, a temporary file beside the target; commit() renames it onto the
/// target, and without commit() (a failed or interrupted run) it is removed, so the target is
/// either complete or as it was. `suffix` is what the library appends to the name it is given
/// (".vcd"): base() is that name, staged() the file it writes.
class StagedOutput {
 public:
  StagedOutput(std::string path, const std::string& suffix);
  ~StagedOutput();
  StagedOutput(const StagedOutput&) = delete;
  StagedOutput& operator=(const StagedOutput&) = delete;
  const std::string& base() const { return base_; }
  const std::string& staged() const { return staged_; }
  /// Renames the (closed) staged file onto the target; throws InputError on failure.
  void commit();

 private:
  std::string path_, target_, base_, staged_;
  bool committed_ = false;
  int slot_ = -1;
};

/// Writes `text` to `path` through an OutputFile.
void write_text_file(const std::string& path, const std::string& text);

}  // namespace xbarsim
