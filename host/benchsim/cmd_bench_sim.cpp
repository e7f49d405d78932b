// `imuforge bench-sim`: the process that stands in for the lab (docs/modbus.md, "bench-sim").
#include <csignal>
#include <cstdio>
#include <string>
#include <thread>

#include <CLI/CLI.hpp>

#include "host/app/command.h"
#include "host/benchsim/bench.h"
#include "host/benchsim/imu_link.h"
#include "host/benchsim/modbus_server.h"
#include "host/benchsim/world_config.h"
#include "host/fixture/register_map.h"

namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

int run_bench_sim(int argc, char** argv) {
  using namespace imuforge;
  CLI::App app{"bench-sim: a simulated rate table and thermal chamber served over Modbus TCP and RTU, and "
               "the virtual IMU on the CAN bus, all in one simulated world (docs/modbus.md)"};
  benchsim::ServerOptions so;
  so.tcp_port = 1502;
  double time_scale = 1.0, duration_s = 0.0;
  std::string table_map = "imuforge-table.json", chamber_map = "imuforge-chamber.json";
  std::string campaign, sensor, world_json;
  std::vector<std::string> buses;
  int slots = 1;
  double nest_sigma_deg = 0.0;
  std::vector<int> dead_slots, outlier_slots;
  std::string outlier_sensor;
  uint64_t seed = 1, serial = 1;
  int node_id = 1;
  bool no_tcp = false, stdin_eof_exits = false;
  app.add_option("--tcp-port", so.tcp_port, "Modbus TCP port (0: pick a free port; default 1502)");
  app.add_flag("--no-tcp", no_tcp, "do not serve Modbus TCP");
  app.add_option("--bind", so.bind, "address to listen on (default 127.0.0.1, loopback only)");
  app.add_flag("--rtu", so.rtu_pty, "serve Modbus RTU on a new pseudo-terminal (its path is announced)");
  app.add_option("--rtu-device", so.rtu_device, "serve Modbus RTU on this existing serial device instead");
  app.add_option("--baud", so.baud, "RTU baud rate (default 115200, 8N1)");
  app.add_option("--unit-id", so.unit_id, "RTU slave address (default 1); TCP answers any unit id")->check(CLI::Range(1, 247));
  app.add_option("--time-scale", time_scale, "simulated seconds per wall second (default 1)")->check(CLI::PositiveNumber);
  app.add_option("--table-map", table_map, "rate-table register map (default imuforge-table.json)");
  app.add_option("--chamber-map", chamber_map, "chamber register map (default imuforge-chamber.json; or watlow-f4.json)");
  app.add_option("--campaign", campaign, "campaign file: table axes, limits, mount, site, chamber limits");
  app.add_option("--world", world_json, "world JSON (overrides; see docs/modbus.md)");
  app.add_option("--sensor", sensor, "sensor model JSON for the virtual IMU");
  app.add_option("--bus", buses, "CAN bus for the virtual IMUs: virtual:NAME or socketcan:IFNAME (none: no IMU); "
                                 "repeat for several buses, slots go round-robin");
  app.add_option("--slots", slots, "virtual IMUs (one per nest): node, serial and seed count up from --node, "
                                   "--serial, --seed")->check(CLI::Range(1, 127));
  app.add_option("--nest-error-deg", nest_sigma_deg, "1σ of each unit's rotation in its nest, per axis, drawn per slot")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--dead-slot", dead_slots, "slot (1-based) whose node never answers; repeatable");
  app.add_option("--outlier-slot", outlier_slots, "slot (1-based) whose part is --outlier-sensor instead; repeatable");
  app.add_option("--outlier-sensor", outlier_sensor, "sensor model JSON of the --outlier-slot parts");
  app.add_option("--seed", seed, "seed of the sensor's noise (default 1)");
  app.add_option("--serial", serial, "serial number of the virtual IMU (default 1)");
  app.add_option("--node", node_id, "CAN node id of the virtual IMU (default 1)")->check(CLI::Range(1, 127));
  app.add_flag("--stdin-eof-exits", stdin_eof_exits,
               "exit when stdin reaches end of file (a parent that dies takes bench-sim with it)");
  app.add_option("--duration", duration_s, "stop after this many wall seconds (default: until SIGINT/SIGTERM)");
  app.add_flag("--debug", so.debug, "dump Modbus frames on stderr");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? app::kExitOk : app::kExitUsage;
  }
  if (no_tcp) so.tcp_port = -1;
  if (so.rtu_pty && !so.rtu_device.empty()) {
    std::fprintf(stderr, "imuforge bench-sim: use either --rtu or --rtu-device, not both\n");
    return app::kExitUsage;
  }

  benchsim::WorldConfig wc;
  try {
    wc = benchsim::world_config(campaign, world_json, sensor, seed);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "imuforge bench-sim: %s\n", e.what());
    return app::exit_code_for(e);
  }
  std::unique_ptr<benchsim::Bench> bench;
  try {
    auto tm = fixture::RegisterMap::load(fixture::resolve_map_path(table_map, ""));
    auto cm = fixture::RegisterMap::load(fixture::resolve_map_path(chamber_map, ""));
    benchsim::RegisterBank bank(std::move(tm), std::move(cm));
    bench = std::make_unique<benchsim::Bench>(benchsim::make_sim_world(wc), std::move(bank), time_scale);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "imuforge bench-sim: %s\n", e.what());
    return app::exit_code_for(e);
  }

  std::signal(SIGPIPE, SIG_IGN);  // a client that vanishes mid-answer must not kill the lab
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  benchsim::ModbusServer server(*bench, so);
  try {
    server.start();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "imuforge bench-sim: %s\n", e.what());
    return app::kExitPeer;
  }
  std::vector<std::unique_ptr<benchsim::ImuLink>> imus;
  std::string bus_list;
  for (const auto& b : buses) bus_list += (bus_list.empty() ? "" : ",") + b;
  if (!buses.empty()) {
    try {
      benchsim::SlotPlan plan;
      plan.slots = slots;
      plan.buses = buses;
      plan.sensor_path = sensor;
      plan.seed = seed;
      plan.first_serial = serial;
      plan.first_node = node_id;
      plan.nest_sigma_rad = nest_sigma_deg * M_PI / 180.0;
      plan.dead = dead_slots;
      plan.outlier = outlier_slots;
      plan.outlier_sensor_path = outlier_sensor;
      for (const auto& io : benchsim::slot_imus(plan)) imus.push_back(benchsim::start_imu(*bench, io));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "imuforge bench-sim: virtual IMU on %s: %s\n", bus_list.c_str(), e.what());
      return app::kExitPeer;
    }
  }

  std::string tcp = server.tcp_port() > 0 ? so.bind + ":" + std::to_string(server.tcp_port()) : "-";
  std::string rtu = server.rtu_path().empty() ? "-" : server.rtu_path();
  std::printf("ready tcp=%s rtu=%s unit=%d time_scale=%g bus=%s slots=%zu\n", tcp.c_str(), rtu.c_str(), so.unit_id,
              time_scale, bus_list.empty() ? "-" : bus_list.c_str(), imus.size());
  std::fflush(stdout);

  if (stdin_eof_exits) {
    std::thread([] {
      char buf[256];
      while (std::fread(buf, 1, sizeof buf, stdin) > 0) {
      }
      g_stop = 1;
    }).detach();
  }
  const auto t_end = std::chrono::steady_clock::now() + std::chrono::duration<double>(duration_s);
  while (!g_stop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    {
      // Keep the world close to "now" so a request after a long quiet spell does not pay for all of it.
      std::lock_guard<std::mutex> lock(bench->mutex());
      bench->sync();
    }
    if (duration_s > 0 && std::chrono::steady_clock::now() >= t_end) break;
  }
  for (auto& i : imus) i->stop();
  for (auto& i : imus) std::fprintf(stderr, "imuforge bench-sim: %s\n", i->summary().c_str());
  server.stop();
  std::fprintf(stderr, "imuforge bench-sim: stopped after %.1f simulated s, %llu Modbus requests, %llu table commands\n",
               bench->now_s(), static_cast<unsigned long long>(server.requests()),
               static_cast<unsigned long long>(bench->bank().commands_applied()));
  return app::kExitOk;
}

}  // namespace

static const imuforge::app::CommandRegistrar reg_bench_sim{
    "bench-sim", "the lab stand-in: rate table + chamber over Modbus TCP/RTU, virtual IMU on CAN", run_bench_sim};
