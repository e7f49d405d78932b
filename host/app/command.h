// Subcommand registry of the `imuforge` program.
//
// Each subcommand lives in its subsystem's folder as host/<area>/cmd_<name>.cpp and registers itself:
//
//     static int run_simulate(int argc, char** argv);   // argv[0] is "imuforge simulate"
//     IMUFORGE_COMMAND(simulate, "simulate a campaign: true motion in, raw IMU samples out", run_simulate);
//
// Exit codes, shared by every subcommand:
//   0  success (and, for commands that judge, PASS)
//   1  the work ran but failed: bad input data, a rejected table, a FAIL verdict (message on stderr)
//   2  usage error (bad options)
//   3  an external peer failed: Modbus fixture, CAN bus, database
#pragma once

namespace imuforge::app {

using CommandFn = int (*)(int argc, char** argv);

enum ExitCode : int { kExitOk = 0, kExitFailed = 1, kExitUsage = 2, kExitPeer = 3 };

struct CommandRegistrar {
  CommandRegistrar(const char* name, const char* summary, CommandFn fn) noexcept;
};

}  // namespace imuforge::app

#define IMUFORGE_COMMAND(name, summary, fn) \
  static const ::imuforge::app::CommandRegistrar imuforge_command_registrar_##name{#name, summary, fn}
