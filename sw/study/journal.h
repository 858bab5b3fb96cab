#pragma once
/// The resumable record of a long run (explore --out, eval --journal): one JSON object per
/// line, each appended whole under an fcntl lock and flushed to disk as its work finishes, so a
/// killed run loses only the work in flight and several MPI ranks can append to one file. A
/// journal is a user's file too: it is only ever cut (the last line a kill left incomplete) or
/// appended to when it is a journal of its kind (its first line is one of that kind's), never a
/// file the run reads in another role (sw/common/input_file.h).
#include <nlohmann/json.hpp>
#include <functional>
#include <string>
#include <vector>

namespace xbarsim {

/// What a journal's lines are.
struct JournalKind {
  std::string name;  ///< in messages: "eval journal", "explore results file"
  std::string flag;  ///< the option that names it: "--journal", "--out"
  /// Whether a parsed line is one of this kind's (the fields that identify it are there with
  /// their types; the values are checked where a line is used).
  std::function<bool(const nlohmann::json&)> recognise;
};

/// A line of a journal: its number (from 1) and its object.
struct JournalLine {
  int number = 0;
  nlohmann::json row;
};

class ResultJournal {
 public:
  /// Opens the journal, creating it when it does not exist. Throws InputError, before anything
  /// is written, when `path` is a file this run reads in another role, is not a regular file (a
  /// journal is read back and appended to: /dev/null would lose it, /dev/zero never ends),
  /// cannot be created, or is not empty and its first line is not one of `kind`'s (the file is
  /// not a journal of this kind: a model, a CSV, another command's journal).
  ResultJournal(std::string path, JournalKind kind);
  /// Drops a last line cut short by a kill (call on one process, before anyone appends).
  void repair() const;
  /// Every complete line that parses as one of this kind's, numbered; the others are counted
  /// in `skipped`.
  std::vector<JournalLine> read(int* skipped = nullptr) const;
  /// Appends one row as one line; throws InputError when the file cannot be written.
  void append(const nlohmann::json& row) const { append_lines(row.dump() + "\n"); }
  /// Appends whole lines ("...\n" each) in one write under the lock.
  void append_lines(const std::string& lines) const;
  const std::string& path() const { return path_; }
  const JournalKind& kind() const { return kind_; }
  /// "the eval journal 'runs/a.jsonl'" and the like, for messages.
  std::string describe() const { return "the " + kind_.name + " '" + path_ + "'"; }

 private:
  std::string path_;
  JournalKind kind_;
};

}  // namespace xbarsim
