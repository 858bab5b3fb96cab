#include "sw/common/output_file.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "sw/common/errors.h"
#include "sw/common/input_file.h"

namespace xbarsim {

namespace {

std::string folder_of(const std::string& path) {
  const auto slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

bool is_special(const struct stat& st) { return !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode); }

/// A temporary file's name in `path`'s folder, short whatever the target's length (a name
/// at the file system's limit still gets its temporary file).
std::string temporary_name(const std::string& path) {
  static std::atomic<int> counter{0};
  return folder_of(path) + "/.xbarsim-" + std::to_string(getpid()) + "-" + std::to_string(counter++) + ".tmp";
}

/// The temporary files of this process, removed by a terminating signal's handler: fixed slots
/// of fixed size, so that the handler only reads memory and calls unlink (async-signal-safe).
constexpr int kSlots = 64;
constexpr size_t kPathMax = 4096;
struct PendingSlot {
  std::atomic<bool> used{false};
  std::atomic<bool> ready{false};
  char path[kPathMax];
};
PendingSlot g_pending[kSlots];

extern "C" void remove_pending_and_die(int sig) {
  for (PendingSlot& s : g_pending)
    if (s.ready.load()) unlink(s.path);
  signal(sig, SIG_DFL);
  raise(sig);
}

void install_cleanup_handlers() {
  static std::atomic<bool> done{false};
  if (done.exchange(true)) return;
  for (int sig : {SIGTERM, SIGHUP, SIGINT}) {
    struct sigaction old {};
    if (sigaction(sig, nullptr, &old) != 0 || old.sa_handler != SIG_DFL || (old.sa_flags & SA_SIGINFO)) continue;
    struct sigaction sa {};
    sa.sa_handler = remove_pending_and_die;
    sigemptyset(&sa.sa_mask);
    sigaction(sig, &sa, nullptr);
  }
}

/// Registers a temporary file for removal on a terminating signal: its slot (-1: none free, or a
/// name too long; the file is then only removed by its owner).
int add_pending(const std::string& path) {
  install_cleanup_handlers();
  if (path.size() >= kPathMax) return -1;
  for (int k = 0; k < kSlots; ++k) {
    bool expected = false;
    if (!g_pending[k].used.compare_exchange_strong(expected, true)) continue;
    std::memcpy(g_pending[k].path, path.c_str(), path.size() + 1);
    g_pending[k].ready.store(true);
    return k;
  }
  return -1;
}

void drop_pending(int slot) {
  if (slot < 0) return;
  g_pending[slot].ready.store(false);
  g_pending[slot].used.store(false);
}

/// Creates and removes `path` (which did not exist): whether a file of that name can be made.
/// (Another process, e.g. another MPI rank probing the same name, may have just made it.)
void probe_create(const std::string& path, const std::string& what, const std::string& shown) {
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
  if (fd < 0 && errno == EEXIST) return;
  if (fd < 0) throw InputError(what + " '" + shown + "': cannot create it: " + std::strerror(errno));
  close(fd);
  unlink(path.c_str());
}

}  // namespace

void refuse_input(const std::string& path, const std::string& what, const std::string& verb) {
  if (const auto in = registered_input(path))
    throw InputError(what + " '" + path + "' is " + in->role + " this run reads" +
                     (in->path == path ? std::string() : " ('" + in->path + "')") + "; refusing to " + verb + " it");
}

void check_output_path(const std::string& path, const std::string& what, const std::vector<std::string>& inputs) {
  if (path.empty()) throw InputError(what + " needs a file name");
  struct stat st;
  const bool exists = stat(path.c_str(), &st) == 0;
  if (exists && S_ISDIR(st.st_mode)) throw InputError(what + " '" + path + "' is a directory; give a file name");
  if (!exists && path.back() == '/') throw InputError(what + " '" + path + "' names a directory; give a file name");
  if (exists && !is_special(st)) {
    refuse_input(path, what);  // first: it names the input's role
    for (const auto& in : inputs)
      if (!in.empty() && same_file(in, path))
        throw InputError(what + " '" + path + "' is the input file '" + in + "'; refusing to overwrite it");
  }
  if (exists && is_special(st)) {
    if (access(path.c_str(), W_OK) != 0) throw InputError(what + " '" + path + "' is not writable");
    return;
  }
  const std::string dir = folder_of(path);
  struct stat sd;
  if (stat(dir.c_str(), &sd) != 0 || !S_ISDIR(sd.st_mode))
    throw InputError(what + " '" + path + "': the folder '" + dir + "' does not exist");
  if (access(dir.c_str(), W_OK) != 0)
    throw InputError(what + " '" + path + "': the folder '" + dir + "' is not writable");
  if (exists && access(path.c_str(), W_OK) != 0) throw InputError(what + " '" + path + "' is not writable");
  // What access() cannot tell (a name too long, a folder that refuses new files such as /proc):
  // create the files the output will need, now rather than after the work.
  if (!exists) probe_create(path, what, path);
  probe_create(temporary_name(path), what, path);
}

namespace {

/// The file an output `path` replaces: an existing name may be a symbolic link (results.json ->
/// runs/a.json, /dev/stdout -> a redirected file): the file it leads to is replaced, not the link.
std::string replaced_file(const std::string& path) {
  char* real = realpath(path.c_str(), nullptr);
  if (!real) return path;
  std::string r = real;
  std::free(real);
  return r;
}

}  // namespace

OutputFile::OutputFile(std::string path) : path_(std::move(path)), target_(path_) {
  struct stat st;
  const bool exists = stat(path_.c_str(), &st) == 0, special = exists && is_special(st);
  if (!special) refuse_input(path_, "the output");
  if (exists && !special) target_ = replaced_file(path_);
  tmp_ = special ? std::string() : temporary_name(target_);
  if (!tmp_.empty()) slot_ = add_pending(tmp_);
  out_.open(special ? path_ : tmp_, std::ios::binary | std::ios::trunc);
  if (!out_) {
    drop_pending(slot_);
    throw InputError("cannot write '" + path_ + "': " + std::strerror(errno));
  }
}

OutputFile::~OutputFile() {
  if (committed_) return;
  out_.close();
  if (!tmp_.empty()) std::remove(tmp_.c_str());
  drop_pending(slot_);
}

void OutputFile::commit() {
  out_.flush();
  const bool flushed = static_cast<bool>(out_);
  const int err = errno;
  out_.close();
  if (!flushed || out_.fail())
    throw InputError("error while writing '" + path_ + "'" + (err ? std::string(": ") + std::strerror(err) : "") +
                     " (disk full?)");
  if (!tmp_.empty()) {
    refuse_input(target_, "the output");  // an input registered since the file was opened
    if (std::rename(tmp_.c_str(), target_.c_str()) != 0)
      throw InputError("cannot replace '" + path_ + "': " + std::strerror(errno));
  }
  drop_pending(slot_);
  committed_ = true;
}

StagedOutput::StagedOutput(std::string path, const std::string& suffix) : path_(std::move(path)), target_(path_) {
  refuse_input(path_, "the output");
  struct stat st;
  if (stat(path_.c_str(), &st) == 0) target_ = replaced_file(path_);
  base_ = temporary_name(target_);
  staged_ = base_ + suffix;
  slot_ = add_pending(staged_);
}

StagedOutput::~StagedOutput() {
  if (!committed_) std::remove(staged_.c_str());
  drop_pending(slot_);
}

void StagedOutput::commit() {
  refuse_input(target_, "the output");
  if (std::rename(staged_.c_str(), target_.c_str()) != 0)
    throw InputError("cannot write '" + path_ + "': " + std::strerror(errno));
  committed_ = true;
  drop_pending(slot_);
  slot_ = -1;
}

void write_text_file(const std::string& path, const std::string& text) {
  OutputFile f(path);
  f.stream() << text;
  f.commit();
}

}  // namespace xbarsim
