// `imuforge can`: talk to an imuforge CAN node (docs/can-protocol.md).
//   imuforge can identify   --bus virtual:bench1 --node 1
//   imuforge can status     --bus ... --node ...
//   imuforge can stream     --bus ... --node ... --rate 1000 --seconds 5 [--out samples.csv]
//   imuforge can read-table --bus ... --node ... --out table.bin
//   imuforge can flash      --bus ... --node ... --table table.bin --seq 7 (--key-hex K | --dev-key)
//   imuforge can reboot     --bus ... --node ...
// Exit codes (host/app/command.h): 0 ok, 1 refused table / bad file, 2 usage, 3 bus or node failure.
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <iterator>
#include <mutex>
#include <thread>

#include <CLI/CLI.hpp>

#include "firmware/table/table.h"
#include "host/app/command.h"
#include "host/can/bus_budget.h"
#include "host/can/client.h"
#include "host/vimu/virtual_imu.h"

namespace {

using namespace imuforge;

int run_can(int argc, char** argv) {
  CLI::App app{"talk to an imuforge CAN node: identify, status, stream, read-table, flash, reboot"};
  app.require_subcommand(1);
  std::string bus = "virtual:imuforge";
  unsigned node = 1;
  bool ext = false;
  int timeout_ms = 1000;
  app.add_option("--bus", bus, "virtual:<name> or socketcan:<ifname>")->capture_default_str();
  app.add_option("--node", node, "node id 0..63")->check(CLI::Range(0, 63))->capture_default_str();
  app.add_flag("--ext", ext, "29-bit identifiers");
  app.add_option("--timeout-ms", timeout_ms, "per-request timeout")->capture_default_str();
  auto* c_id = app.add_subcommand("identify", "serial, firmware version, active table");
  auto* c_st = app.add_subcommand("status", "node counters");
  auto* c_stream = app.add_subcommand("stream", "stream samples and report lost/duplicated/reordered counts");
  unsigned rate = 1000, channels = 7;
  double seconds = 2.0;
  std::string out;
  c_stream->add_option("--rate", rate, "Hz, 1..2000")->check(CLI::Range(1, 2000))->capture_default_str();
  c_stream->add_option("--channels", channels, "1 accel, 2 gyro, 4 temp (sum)")->check(CLI::Range(1, 7))->capture_default_str();
  c_stream->add_option("--seconds", seconds, "duration")->capture_default_str();
  c_stream->add_option("--out", out, "write samples as CSV");
  bool stream_fd = false;
  c_stream->add_flag("--fd", stream_fd, "CAN FD stream frames, 4 samples per 64-byte frame (docs/can-protocol.md)");
  auto* c_read = app.add_subcommand("read-table", "read the active coefficient table");
  c_read->add_option("--out", out, "output file")->required();
  auto* c_flash = app.add_subcommand("flash", "write, commit and verify a coefficient table");
  std::string table_path, key_hex;
  std::uint32_t seq = 0;
  bool dev_key = false;
  c_flash->add_option("--table", table_path, "table v1 file")->required()->check(CLI::ExistingFile);
  c_flash->add_option("--seq", seq, "sequence number (default: the table's own table_sequence)");
  c_flash->add_option("--key-hex", key_hex, "device key, 64 hex digits");
  c_flash->add_flag("--dev-key", dev_key, "use the public development key of the node's serial (virtual IMU)");
  auto* c_reboot = app.add_subcommand("reboot", "reset the node");
  auto* c_budget = app.add_subcommand("budget", "bus load of N units streaming (worst-case stuffing); exit 1 above the limit");
  int units = 1, buses = 1;
  double budget_rate = 200, limit = can::kDefaultLoadLimit;
  can::BusTiming timing;
  bool table = false;
  c_budget->add_option("--units", units, "units streaming")->check(CLI::Range(1, 1024))->capture_default_str();
  c_budget->add_option("--rate", budget_rate, "stream rate, Hz")->check(CLI::Range(1.0, 2000.0))->capture_default_str();
  c_budget->add_option("--buses", buses, "buses the units are spread over evenly")->check(CLI::Range(1, 64))->capture_default_str();
  c_budget->add_flag("--fd", timing.fd, "CAN FD stream frames (docs/can-protocol.md)");
  c_budget->add_option("--bitrate", timing.nominal_bit_s, "nominal (arbitration) bit rate, bit/s")->capture_default_str();
  c_budget->add_option("--data-bitrate", timing.data_bit_s, "CAN FD data bit rate, bit/s")->capture_default_str();
  c_budget->add_option("--limit", limit, "refuse above this fraction of the bus")->check(CLI::Range(0.01, 1.0))->capture_default_str();
  c_budget->add_flag("--table", table, "print the load for 1, 4, 8, 16 units at 200 Hz and 1 kHz, classic and FD");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? app::kExitOk : app::kExitUsage;
  }
  if (c_budget->parsed()) {
    timing.ext_id = ext;
    if (table) {
      can::BusTiming fd = timing;
      fd.fd = true;
      can::BusTiming classic = timing;
      classic.fd = false;
      std::printf("worst-case bus load, %s ids, classic %.0f kbit/s, FD %.0f/%.0f kbit/s (%d samples per frame)\n",
                  ext ? "29-bit" : "11-bit", classic.nominal_bit_s / 1e3, fd.nominal_bit_s / 1e3, fd.data_bit_s / 1e3,
                  can::kFdSamplesPerFrame);
      std::printf("| units | 200 Hz classic | 200 Hz FD | 1 kHz classic | 1 kHz FD |\n|---|---|---|---|---|\n");
      for (int n : {1, 4, 8, 16})
        std::printf("| %d | %.1f %% | %.1f %% | %.1f %% | %.1f %% |\n", n, 100 * can::stream_load_worst(classic, n, 200),
                    100 * can::stream_load_worst(fd, n, 200), 100 * can::stream_load_worst(classic, n, 1000),
                    100 * can::stream_load_worst(fd, n, 1000));
      return app::kExitOk;
    }
    std::vector<can::BusPlan> plan;
    for (int b = 0; b < buses; ++b) plan.push_back({"#" + std::to_string(b), units / buses + (b < units % buses ? 1 : 0)});
    const can::BudgetVerdict v = can::check_budget(timing, plan, budget_rate, limit);
    for (std::size_t b = 0; b < plan.size(); ++b)
      std::printf("bus %s: %d units at %.0f Hz: %.1f %% worst case (%.1f %% without stuffing)\n", plan[b].bus.c_str(),
                  plan[b].units, budget_rate, 100 * v.load[b], 100 * can::stream_load_nominal(timing, plan[b].units, budget_rate));
    if (!v.ok) {
      std::fprintf(stderr, "imuforge can budget: %s\n", v.message.c_str());
      return app::kExitFailed;
    }
    return app::kExitOk;
  }
  if (c_flash->parsed() && key_hex.empty() == !dev_key) {
    std::cerr << "imuforge can flash: give exactly one of --key-hex and --dev-key\n";
    return app::kExitUsage;
  }
  try {
    can::Client::Options o;
    o.extended_ids = ext;
    o.timeout_ms = timeout_ms;
    auto c = can::Client::connect(bus, static_cast<std::uint8_t>(node), o);
    if (c_id->parsed()) {
      const auto id = c->identify();
      std::printf("serial %" PRIu64 "\nfirmware %s\nnode %u (%s ids)\nkey %s\ncan_fd %s\n", id.serial, id.fw_version.c_str(),
                  id.node_id, id.extended_ids ? "29-bit" : "11-bit", id.key_provisioned ? "provisioned" : "MISSING",
                  id.can_fd ? "yes" : "no");
      if (id.table_present) {
        std::printf("table seq %u, %u bytes, crc32 0x%08x\n", id.table_seq, id.table_len, id.table_crc32);
      } else {
        std::printf("table none\n");
      }
    } else if (c_st->parsed()) {
      const auto s = c->status();
      std::printf("uptime_ms %u\nboots %u\nsamples_sent %u\nstream_frames_tx %u\nstream_frames_dropped %u\n"
                  "bus_off_events %u\nisotp_rx_errors %u\nisotp_tx_errors %u\ncommands_ok %u\ncommands_rejected %u\n"
                  "auth_failures %u\nactive_slot %d\nstaged_slot %d\nstreaming %d (%u Hz, channels %u)\n"
                  "samples_fifo_overflow %u\n",
                  s.uptime_ms, s.boots, s.samples_sent, s.stream_frames_tx, s.stream_frames_dropped, s.bus_off_events,
                  s.isotp_rx_errors, s.isotp_tx_errors, s.commands_ok, s.commands_rejected, s.auth_failures,
                  s.active_slot, s.staged_slot, s.streaming ? (s.stream_fd ? 2 : 1) : 0, s.rate_hz, s.channels, s.samples_fifo_overflow);
    } else if (c_stream->parsed()) {
      std::ofstream csv;
      if (!out.empty()) {
        csv.open(out);
        if (!csv) {
          std::cerr << "imuforge can stream: cannot write " << out << "\n";
          return app::kExitFailed;
        }
        csv << "seq,t_us,ax,ay,az,gx,gy,gz,temp_cdegC\n";
      }
      std::mutex mu;
      c->start_stream(static_cast<std::uint16_t>(rate), static_cast<std::uint8_t>(channels),
                      [&](const can::StreamSample& s) {
                        if (!csv.is_open()) return;
                        std::lock_guard<std::mutex> lk(mu);
                        csv << s.seq << ',' << s.t_us << ',' << s.accel_counts[0] << ',' << s.accel_counts[1] << ','
                            << s.accel_counts[2] << ',' << s.gyro_counts[0] << ',' << s.gyro_counts[1] << ','
                            << s.gyro_counts[2] << ',' << s.temp_cdegC << '\n';
                      },
                      stream_fd);
      std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
      c->stop_stream();
      const auto k = c->stream_counters();
      std::printf("received %" PRIu64 " lost %" PRIu64 " incomplete %" PRIu64 " duplicated %" PRIu64
                  " reordered %" PRIu64 " frames %" PRIu64 " frames_lost %" PRIu64 " malformed %" PRIu64 "\n",
                  k.received, k.lost, k.incomplete, k.duplicated, k.reordered, k.frames, k.frames_lost, k.malformed);
    } else if (c_read->parsed()) {
      std::uint32_t s = 0;
      const auto t = c->read_table(&s);
      std::ofstream f(out, std::ios::binary);
      f.write(reinterpret_cast<const char*>(t.data()), static_cast<std::streamsize>(t.size()));
      if (!f) {
        std::cerr << "imuforge can read-table: cannot write " << out << "\n";
        return app::kExitFailed;
      }
      std::printf("table seq %u, %zu bytes -> %s\n", s, t.size(), out.c_str());
    } else if (c_flash->parsed()) {
      std::ifstream f(table_path, std::ios::binary);
      std::vector<std::uint8_t> t((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
      static fw::Table parsed;
      const int rc = fw::table_parse(t.data(), t.size(), &parsed);
      if (rc != 0) {
        std::cerr << "imuforge can flash: " << table_path << " is not a valid table v1: " << fw::table_strerror(rc) << "\n";
        return app::kExitBadInput;
      }
      if (seq == 0) seq = parsed.table_sequence;
      const auto id = c->identify();
      if (parsed.device_serial != id.serial) {
        std::cerr << "imuforge can flash: table is for serial " << parsed.device_serial << ", node " << node
                  << " has serial " << id.serial << "\n";
        return app::kExitBadInput;
      }
      const can::Key key = dev_key ? vimu::dev_key_for_serial(id.serial) : can::key_from_hex(key_hex);
      const auto t0 = std::chrono::steady_clock::now();
      c->flash_table(t, seq, key, id.serial);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      std::printf("flashed table seq %u (%zu bytes) in %.1f ms, verified by read-back\n", seq, t.size(), ms);
    } else if (c_reboot->parsed()) {
      c->reboot();
      std::printf("node %u rebooting\n", node);
    }
  } catch (const can::Error& e) {
    std::cerr << "imuforge can: " << e.what() << "\n";
    return e.is_peer_refusal() ? app::kExitFailed : app::kExitPeer;
  } catch (const std::invalid_argument& e) {
    std::cerr << "imuforge can: " << e.what() << "\n";
    return app::kExitUsage;
  }
  return app::kExitOk;
}

}  // namespace

IMUFORGE_COMMAND(can, "talk to an imuforge CAN node: identify, status, stream, read-table, flash, reboot; bus budget", run_can);
