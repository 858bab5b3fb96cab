#include <chrono>
#include <iomanip>
#include <iostream>

#include "sw/app/app_common.h"
#include "sw/circuit/crossbar_solver.h"
#include "sw/common/csv.h"

namespace xbarsim {

namespace {
void warn_ranges(const CrossbarParams& p, const Eigen::MatrixXd& g, const Eigen::MatrixXd& v) {
  const double tol = 1e-9;
  if (g.minCoeff() < p.g_min_s * (1 - tol) || g.maxCoeff() > p.g_max_s * (1 + tol))
    std::cerr << "xbarsim solve: warning: conductances span [" << g.minCoeff() << ", " << g.maxCoeff()
              << "] S, outside the programmable range [crossbar.g_min, crossbar.g_max] = [" << p.g_min_s << ", "
              << p.g_max_s << "] S\n";
  if (v.size() && v.cwiseAbs().maxCoeff() > p.v_in_max_v * (1 + tol))
    std::cerr << "xbarsim solve: warning: input voltages reach " << v.cwiseAbs().maxCoeff()
              << " V, beyond crossbar.v_in_max = " << p.v_in_max_v << " V\n";
}
}  // namespace

namespace {
int cmd_solve(int argc, char** argv) {
  const CliArgs args(argc, argv, 0, {"--conductances", "--inputs", "--out"});
  const ConfigTree cfg = load_config(args);
  const CrossbarParams params = parse_crossbar_params(cfg);
  const SolverOptions opts = parse_solver_options(cfg);
  const Eigen::MatrixXd g = read_csv_matrix(args.require("--conductances"), "the conductances (--conductances)");
  const Eigen::MatrixXd v = read_csv_matrix(args.require("--inputs"), "the input vectors (--inputs)");
  check_outputs(args, {"--out", "--json", "--csv"});
  if (v.cols() != g.rows())
    throw InputError("'" + args.require("--inputs") + "' has " + std::to_string(v.cols()) +
                     " voltages per line, but the conductance matrix has " + std::to_string(g.rows()) +
                     " rows (one voltage per row is needed)");
  warn_ranges(params, g, v);

  const auto t0 = std::chrono::steady_clock::now();
  auto solver = make_crossbar_solver(params, opts);
  solver->program(g);
  // The sensed outputs: column currents (A), or column voltages (V) with crossbar.sensing: voltage.
  const Eigen::MatrixXd currents = solver->column_outputs(v);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

  const std::string out = args.has("--out") ? args.get("--out") : args.get("--csv");
  if (!out.empty()) {
    write_csv_matrix(out, currents);
  } else {
    std::cout << std::setprecision(17);
    for (Eigen::Index k = 0; k < currents.rows(); ++k) {
      for (Eigen::Index j = 0; j < currents.cols(); ++j) std::cout << (j ? "," : "") << currents(k, j);
      std::cout << "\n";
    }
  }
  if (args.has("--csv") && args.has("--out")) write_csv_matrix(args.get("--csv"), currents);
  std::cerr << "xbarsim solve: " << g.rows() << "x" << g.cols() << " crossbar, " << v.rows()
            << " input vector(s), memristor=" << to_string(params.memristor.model)
            << ", transistor=" << to_string(params.transistor.model) << ", sensing=" << to_string(params.sensing)
            << ", solver=" << to_string(opts.method) << ": "
            << std::fixed << std::setprecision(2) << ms << " ms\n";
  if (args.has("--json")) {
    nlohmann::json j;
    j["command"] = "solve";
    j["rows"] = g.rows();
    j["cols"] = g.cols();
    j["vectors"] = v.rows();
    j["memristor_model"] = to_string(params.memristor.model);
    j["transistor_model"] = to_string(params.transistor.model);
    j["solver"] = to_string(opts.method);
    j["sensing"] = to_string(params.sensing);
    j["wall_time_ms"] = ms;
    const char* key = params.voltage_sensing() ? "column_voltages_v" : "column_currents_a";
    j[key] = nlohmann::json::array();
    for (Eigen::Index k = 0; k < currents.rows(); ++k) {
      std::vector<double> row(currents.cols());
      for (Eigen::Index c = 0; c < currents.cols(); ++c) row[c] = currents(k, c);
      j[key].push_back(row);
    }
    write_json(args.get("--json"), j);
  }
  return 0;
}
}  // namespace

namespace {
const CommandRegistrar kRegister{
    "solve", cmd_solve,
    "solve --conductances G.csv --inputs V.csv [--out I.csv] [--config F] [--set k=v]... [--json F]\n      column "
    "currents (A) of one crossbar for each input vector (one line of n per vector); column voltages (V) with "
    "crossbar.sensing: voltage"};
}  // namespace

}  // namespace xbarsim
