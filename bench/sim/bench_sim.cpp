// bench_sim: time and disk size to make each simulated session (sessions A-D of the
// default campus for every LiDAR model, and the corridor's session A). Prints a table and
// writes bench/results/sim.json. Logs are deleted after measuring unless --keep.

#include <cstdio>
#include <filesystem>

#include "app/program.hpp"
#include "eval/json_writer.hpp"
#include "liloc_sim/session_writer.hpp"
#include "sim/lidar_model.hpp"
#include "sim/session_recipe.hpp"
#include "storage/file_io.hpp"

namespace {
using namespace liloc;

struct Row {
  std::string world, lidar, session;
  tools::SessionOutput out;
};

}  // namespace

int main(int argc, char** argv) {
  std::string scratch = "data/bench_sim";
  std::string json_path = "bench/results/sim.json";
  std::string lidars = "all";
  std::string sessions = "A,B,C,D";
  std::string worlds = "campus,corridor";
  int threads = 2;
  bool keep = false;
  CommandLine cli("bench_sim", "Time and disk size to simulate each session.");
  cli.add_option("scratch", &scratch, "where sessions are written while measured");
  cli.add_option("json", &json_path, "result file");
  cli.add_option("lidar", &lidars, "comma list of models, or all");
  cli.add_option("sessions", &sessions, "sessions of the campus (the corridor makes A only)");
  cli.add_option("worlds", &worlds, "campus, corridor or campus,corridor");
  cli.add_option("threads", &threads, "ray-casting threads");
  cli.add_flag("keep", &keep, "keep the generated sessions");
  return run_program(cli, "bench_sim", argc, argv, [&]() -> int {
    const std::vector<std::string> models =
        lidars == "all" ? sim::lidar_models() : split_list(lidars);
    std::vector<Row> rows;
    std::printf(
        "| world | lidar | session | length (m) | duration (s) | sweeps | points/sweep | "
        "log (MB) | MB per km | wall (s) | x real time |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (const std::string& kind : split_list(worlds)) {
      sim::SimulationConfig config;
      config.world.kind = kind;
      const sim::SimulatedSessions simulated(config);
      const std::vector<std::string> names =
          kind == "campus" ? split_list(sessions) : std::vector<std::string>{"A"};
      for (size_t si = 0; si < names.size(); ++si) {
        const std::string& name = names[si];
        const sim::SimulatedSession session = simulated.session(name);
        for (const std::string& model : models) {
          const std::string dir = scratch + "/" + kind + "/" + model + "/" + name;
          Row row{kind, model, name,
                  tools::write_session(session, config, model, dir, threads, false)};
          const tools::SessionOutput& o = row.out;
          std::printf("| %s | %s | %s | %.0f | %.0f | %lld | %.0f | %.0f | %.0f | %.1f | %.1f |\n",
                      kind.c_str(), model.c_str(), name.c_str(), o.length_m, o.duration_s,
                      static_cast<long long>(o.stats.sweeps),
                      static_cast<double>(o.stats.points) / o.stats.sweeps, o.log_bytes / 1e6,
                      o.log_bytes / 1e6 / (o.length_m / 1000.0), o.wall_time_s,
                      o.duration_s / o.wall_time_s);
          std::fflush(stdout);
          rows.push_back(row);
          if (!keep) {
            std::filesystem::remove_all(dir);
          }
        }
      }
    }
    eval::JsonWriter json;
    json.begin_object().key("benchmark").string("sim").key("threads").integer(threads);
    json.key("runs").begin_array();
    for (const Row& r : rows) {
      json.begin_object()
          .key("world")
          .string(r.world)
          .key("lidar")
          .string(r.lidar)
          .key("session")
          .string(r.session)
          .key("length_m")
          .number(r.out.length_m)
          .key("duration_s")
          .number(r.out.duration_s)
          .key("sweeps")
          .integer(r.out.stats.sweeps)
          .key("points")
          .integer(r.out.stats.points)
          .key("log_bytes")
          .integer(static_cast<int64_t>(r.out.log_bytes))
          .key("wall_s")
          .number(r.out.wall_time_s)
          .end_object();
    }
    json.end_array().end_object();
    storage::write_file_creating_directories(json_path, json.str());
    return 0;
  });
}
