#include "sw/study/journal.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "sw/common/errors.h"
#include "sw/common/input_file.h"
#include "sw/common/output_file.h"

namespace xbarsim {

namespace {

/// A first line longer than this is not one of ours (our longest lines are a few kB).
constexpr size_t kMaxFirstLine = size_t{1} << 20;

}  // namespace

ResultJournal::ResultJournal(std::string path, JournalKind kind) : path_(std::move(path)), kind_(std::move(kind)) {
  const std::string what = "the " + kind_.name + " (" + kind_.flag + ")";
  if (const auto in = registered_input(path_))
    if (in->role != what) refuse_input(path_, what, "append to");
  struct stat st;
  const bool exists = stat(path_.c_str(), &st) == 0;
  if (exists && !S_ISREG(st.st_mode))
    throw InputError(describe() + " is not a regular file; a journal is read back and appended to");
  if (exists && st.st_size > 0) {
    // Ours only if its first line is: anything else is a user's file that must stay as it is.
    std::ifstream in(path_, std::ios::binary);
    std::string first;
    const LineRead r = read_line(in, first, kMaxFirstLine);
    const nlohmann::json j = nlohmann::json::parse(first, nullptr, false);
    // A kill can cut the very first line short: a lone unfinished line that starts as ours do.
    const bool cut_first_line = r == LineRead::Unfinished && first.rfind("{\"", 0) == 0;
    if (!cut_first_line && (r == LineRead::TooLong || j.is_discarded() || !j.is_object() || !kind_.recognise(j)))
      throw InputError(describe() + " is not an " + kind_.name +
                       ": its first line is not one of ours, so it is left as it is, refusing to cut or append to it "
                       "(give a new file, or one that " +
                       kind_.flag + " wrote)");
  }
  // Created now, so that a place that refuses files (e.g. /sys) fails before the work, not after.
  const int fd = open(path_.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  if (fd < 0) throw InputError("cannot write " + describe() + ": " + std::strerror(errno));
  close(fd);
  register_input(path_, what);
}

void ResultJournal::repair() const {
  std::ifstream in(path_, std::ios::binary);
  if (!in) return;
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  if (text.empty() || text.back() == '\n') return;
  const size_t keep = text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1;
  if (truncate(path_.c_str(), static_cast<off_t>(keep)) != 0)
    throw InputError("cannot repair " + describe() + ": " + std::strerror(errno));
  std::fprintf(stderr, "xbarsim: dropped an incomplete last line of %s (cut short by a kill)\n", path_.c_str());
}

std::vector<JournalLine> ResultJournal::read(int* skipped) const {
  std::vector<JournalLine> rows;
  int bad = 0, number = 0;
  std::ifstream in(path_);
  std::string line;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty()) continue;
    nlohmann::json j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded() || !j.is_object() || !kind_.recognise(j)) {
      ++bad;
      continue;
    }
    rows.push_back({number, std::move(j)});
  }
  if (skipped) *skipped = bad;
  return rows;
}

void ResultJournal::append_lines(const std::string& line) const {
  if (line.empty()) return;
  const int fd = open(path_.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  if (fd < 0) throw InputError("cannot open " + describe() + ": " + std::strerror(errno));
  struct flock lock {};
  lock.l_type = F_WRLCK;
  lock.l_whence = SEEK_SET;
  while (fcntl(fd, F_SETLKW, &lock) < 0 && errno == EINTR) {
  }
  size_t done = 0;
  bool ok = true;
  while (done < line.size()) {
    const ssize_t w = write(fd, line.data() + done, line.size() - done);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) {
      ok = false;
      break;
    }
    done += static_cast<size_t>(w);
  }
  const int err = errno;
  ok = ok && fsync(fd) == 0;
  close(fd);  // releases the lock
  if (!ok) throw InputError("cannot write " + describe() + ": " + std::strerror(err));
}

}  // namespace xbarsim
