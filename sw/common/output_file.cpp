#include "sw/common/output_file.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "sw/common/errors.h"

namespace xbarsim {

namespace {

std::string folder_of(const std::string& path) {
  const auto slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

bool is_special(const struct stat& st) { return !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode); }

}  // namespace

void check_output_path(const std::string& path, const std::string& what, const std::vector<std::string>& inputs) {
  if (path.empty()) throw InputError(what + " needs a file name");
  struct stat st;
  const bool exists = stat(path.c_str(), &st) == 0;
  if (exists && S_ISDIR(st.st_mode)) throw InputError(what + " '" + path + "' is a directory; give a file name");
  if (!exists && path.back() == '/') throw InputError(what + " '" + path + "' names a directory; give a file name");
  if (exists) {
    for (const auto& in : inputs) {
      struct stat si;
      if (!in.empty() && stat(in.c_str(), &si) == 0 && si.st_dev == st.st_dev && si.st_ino == st.st_ino &&
          !is_special(st))
        throw InputError(what + " '" + path + "' is the input file '" + in + "'; refusing to overwrite it");
    }
    if (is_special(st)) {
      if (access(path.c_str(), W_OK) != 0) throw InputError(what + " '" + path + "' is not writable");
      return;
    }
  }
  const std::string dir = folder_of(path);
  struct stat sd;
  if (stat(dir.c_str(), &sd) != 0 || !S_ISDIR(sd.st_mode))
    throw InputError(what + " '" + path + "': the folder '" + dir + "' does not exist");
  if (access(dir.c_str(), W_OK) != 0)
    throw InputError(what + " '" + path + "': the folder '" + dir + "' is not writable");
  if (exists && access(path.c_str(), W_OK) != 0) throw InputError(what + " '" + path + "' is not writable");
}

OutputFile::OutputFile(std::string path) : path_(std::move(path)) {
  struct stat st;
  const bool special = stat(path_.c_str(), &st) == 0 && is_special(st);
  tmp_ = special ? std::string() : path_ + ".tmp" + std::to_string(getpid());
  out_.open(special ? path_ : tmp_, std::ios::binary | std::ios::trunc);
  if (!out_) throw InputError("cannot write '" + path_ + "': " + std::strerror(errno));
}

OutputFile::~OutputFile() {
  if (committed_) return;
  out_.close();
  if (!tmp_.empty()) std::remove(tmp_.c_str());
}

void OutputFile::commit() {
  out_.flush();
  const bool flushed = static_cast<bool>(out_);
  const int err = errno;
  out_.close();
  if (!flushed || out_.fail())
    throw InputError("error while writing '" + path_ + "'" + (err ? std::string(": ") + std::strerror(err) : "") +
                     " (disk full?)");
  if (!tmp_.empty() && std::rename(tmp_.c_str(), path_.c_str()) != 0)
    throw InputError("cannot replace '" + path_ + "': " + std::strerror(errno));
  committed_ = true;
}

void write_text_file(const std::string& path, const std::string& text) {
  OutputFile f(path);
  f.stream() << text;
  f.commit();
}

}  // namespace xbarsim
