#include "sw/common/ranks.h"

#include <algorithm>
#include <cstdlib>

#include "sw/common/errors.h"

#ifdef XBARSIM_HAVE_MPI
#include <mpi.h>
#endif

namespace xbarsim {

namespace {

int g_rank = 0, g_size = 1;
[[maybe_unused]] bool g_mpi = false;

/// The world size an MPI launcher announced in the environment (Open MPI, PMIx, PMI/Slurm), or 0.
int launcher_size() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_SIZE", "PMI_SIZE"})
    if (const char* v = std::getenv(name)) return std::atoi(v);
  if (std::getenv("PMIX_RANK")) return 2;  // PMIx without a size variable: assume a job
  return 0;
}

}  // namespace

void Ranks::init(int* argc, char*** argv) {
  const int announced = launcher_size();
#ifdef XBARSIM_HAVE_MPI
  if (announced <= 0) return;
  int provided = 0;
  MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
  MPI_Comm_size(MPI_COMM_WORLD, &g_size);
  g_mpi = true;
#else
  (void)argc;
  (void)argv;
  if (announced > 1)
    throw InputError("started by an MPI launcher with " + std::to_string(announced) +
                     " ranks, but this xbarsim was built without MPI (install libopenmpi-dev and rebuild), "
                     "so every rank would run the whole command; run it without mpirun");
#endif
}

void Ranks::finalize() {
#ifdef XBARSIM_HAVE_MPI
  if (g_mpi) MPI_Finalize();
  g_mpi = false;
#endif
}

void Ranks::abort(int code) {
#ifdef XBARSIM_HAVE_MPI
  if (g_mpi && g_size > 1) MPI_Abort(MPI_COMM_WORLD, code);
#endif
  std::exit(code);
}

int Ranks::rank() { return g_rank; }
int Ranks::size() { return g_size; }

bool Ranks::built_with_mpi() {
#ifdef XBARSIM_HAVE_MPI
  return true;
#else
  return false;
#endif
}

std::vector<std::string> Ranks::gather(const std::string& mine) {
  if (g_size == 1) return {mine};
#ifdef XBARSIM_HAVE_MPI
  // Sizes first, then the bytes; shares above 2 GiB go in pieces of at most 1 GiB.
  const long long n = static_cast<long long>(mine.size());
  std::vector<long long> sizes(g_rank == 0 ? g_size : 0);
  MPI_Gather(&n, 1, MPI_LONG_LONG, sizes.data(), 1, MPI_LONG_LONG, 0, MPI_COMM_WORLD);
  std::vector<std::string> all(g_rank == 0 ? g_size : 0);
  if (g_rank == 0) {
    all[0] = mine;
    for (int r = 1; r < g_size; ++r) {
      all[r].resize(static_cast<size_t>(sizes[r]));
      for (long long off = 0; off < sizes[r]; off += 1LL << 30) {
        const int len = static_cast<int>(std::min<long long>(1LL << 30, sizes[r] - off));
        MPI_Recv(&all[r][static_cast<size_t>(off)], len, MPI_CHAR, r, 1, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      }
    }
  } else {
    for (long long off = 0; off < n; off += 1LL << 30) {
      const int len = static_cast<int>(std::min<long long>(1LL << 30, n - off));
      MPI_Send(mine.data() + off, len, MPI_CHAR, 0, 1, MPI_COMM_WORLD);
    }
  }
  return all;
#else
  return {mine};
#endif
}

void Ranks::barrier() {
#ifdef XBARSIM_HAVE_MPI
  if (g_mpi && g_size > 1) MPI_Barrier(MPI_COMM_WORLD);
#endif
}

}  // namespace xbarsim
