#pragma once
/// The processes of one run: the ranks of an MPI job (mpirun, srun) when xbarsim is built
/// with MPI and started by an MPI launcher, else a single rank. Commands that shard work
/// (explore, eval, xbar-study) give each rank its share and let rank 0 gather and write.
#include <string>
#include <vector>

namespace xbarsim {

class Ranks {
 public:
  /// Joins the MPI job when an MPI launcher started this process (MPI_Init); otherwise
  /// nothing. Throws InputError when a launcher started several ranks of a build without MPI
  /// (each would run the whole command and overwrite the others' files).
  static void init(int* argc, char*** argv);
  /// Leaves the MPI job (MPI_Finalize); nothing without one.
  static void finalize();
  /// Ends every rank of the job with `code` (MPI_Abort): one rank's error must not leave the
  /// others waiting for it. Without MPI: std::exit(code).
  [[noreturn]] static void abort(int code);

  static int rank();
  static int size();
  static bool root() { return rank() == 0; }
  /// Whether this build has MPI.
  static bool built_with_mpi();

  /// Collective: every rank's `mine`, in rank order, at rank 0; an empty list elsewhere.
  static std::vector<std::string> gather(const std::string& mine);
  /// Collective: waits for every rank.
  static void barrier();
};

}  // namespace xbarsim
