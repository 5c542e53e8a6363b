// liloc_sim: makes simulated multi-session datasets (sessions A-D over one world) as LCM
// logs with ground truth, for every LiDAR model.
//
//   liloc_sim --out data/sim [--world campus] [--lidar hdl32|all] [--sessions A,B,C,D]

#include <spdlog/spdlog.h>

#include <cstdio>

#include "app/program.hpp"
#include "config/yaml_config.hpp"
#include "liloc_sim/session_writer.hpp"
#include "sim/lidar_model.hpp"
#include "sim/random.hpp"

namespace {
using namespace liloc;

}  // namespace

int main(int argc, char** argv) {
  std::string config_path;
  std::string out_dir = "data/sim";
  std::string world_kind;
  std::string lidars = "hdl32";
  std::string sessions = "A,B,C,D";
  int seed = -1;
  int threads = 2;
  double length_scale = 1.0;
  bool print_config = false;
  CommandLine cli("liloc_sim", "Simulate a multi-session LiDAR-inertial dataset.");
  cli.add_option("config", &config_path,
                 "YAML file with a 'sim' section (liloc_sim --print-config writes one)");
  cli.add_option("out", &out_dir, "output folder; sessions go to <out>/<world>/<lidar>/<session>/");
  cli.add_option("world", &world_kind, "campus or corridor (overrides the config)");
  cli.add_option("seed", &seed, "world seed (overrides the config)");
  cli.add_option("lidar", &lidars, "vlp16, hdl32, os1_64, mid360, a comma list, or 'all'");
  cli.add_option("sessions", &sessions, "comma list of A, B, C, D");
  cli.add_option("threads", &threads, "ray-casting threads");
  cli.add_option("length-scale", &length_scale, "scale every session's route length (short tests)");
  cli.add_flag("print-config", &print_config, "print the effective config and exit");
  return run_program(cli, "liloc_sim", argc, argv, [&]() -> int {
    sim::SimulationConfig config = config_path.empty()
                                       ? sim::SimulationConfig{}
                                       : load_config<sim::SimulationConfig>(config_path, "sim");
    if (!world_kind.empty()) {
      config.world.kind = world_kind;
    }
    if (seed >= 0) {
      config.world.seed = seed;
    }
    if (length_scale <= 0.0) {
      throw std::invalid_argument("--length-scale must be positive");
    }
    config.sessions.a_length_m *= length_scale;
    config.sessions.b_inside_m *= length_scale;
    config.sessions.b_excursion_m *= length_scale;
    config.sessions.c_length_m *= length_scale;
    config.sessions.d_length_m *= length_scale;
    if (print_config) {
      std::printf("sim:\n%s\n", dump_config(config).c_str());
      return 0;
    }
    const std::vector<std::string> models =
        lidars == "all" ? sim::lidar_models() : split_list(lidars);
    for (const std::string& m : models) {
      sim::lidar_spec(m);  // fail before simulating anything
    }

    spdlog::info("generating {} world (seed {})", config.world.kind, config.world.seed);
    sim::GeneratedWorld base = sim::generate_world(config.world);
    sim::World changed = base.world;
    const sim::DayChangeReport changes =
        sim::apply_day_changes(changed, config.world.seed + 1, config.changes);
    spdlog::info(
        "world: {} objects, {} primitives; day 1: {} of {} cars moved, {} removed, {} "
        "new structures, {} foliage changed",
        base.world.objects().size(), base.world.num_primitives(), changes.cars_moved,
        changes.cars_total, changes.cars_removed, changes.structures_added,
        changes.foliage_changed);

    std::printf("%-9s %-7s %-3s %9s %9s %7s %10s %9s %9s\n", "world", "lidar", "ses", "length_m",
                "duration", "sweeps", "points", "log_MB", "wall_s");
    int session_index = 0;
    for (const std::string& name : split_list(sessions)) {
      const uint64_t session_seed = sim::hash_combine(static_cast<uint64_t>(config.world.seed),
                                                      static_cast<uint64_t>(name[0]));
      const sim::SessionPlan plan =
          sim::plan_session(name, base.world, base.mapped_max_x_m, config.sessions, session_seed);
      const sim::World& world = plan.day == 0 ? base.world : changed;
      const int64_t start_utime =
          config.start_utime + session_index * config.days_between_sessions * 86400LL * 1000000LL;
      ++session_index;
      for (const std::string& model : models) {
        const std::string dir = out_dir + "/" + config.world.kind + "/" + model + "/" + name;
        const tools::SessionOutput out = tools::write_session(
            world, plan, config, model, start_utime, session_seed, dir, threads, true);
        std::printf("%-9s %-7s %-3s %9.1f %9.1f %7lld %10lld %9.1f %9.1f\n",
                    config.world.kind.c_str(), model.c_str(), name.c_str(), out.length_m,
                    out.duration_s, static_cast<long long>(out.stats.sweeps),
                    static_cast<long long>(out.stats.points), out.log_bytes / 1e6, out.wall_time_s);
        std::fflush(stdout);
      }
    }
    return 0;
  });
}
