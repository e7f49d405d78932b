// Subcommand registry of the `imuforge` program.
//
// Each subcommand lives in its subsystem's folder as host/<area>/cmd_<name>.cpp and registers itself:
//
//     static int run_simulate(int argc, char** argv);   // argv[0] is "imuforge simulate"
//     IMUFORGE_COMMAND(simulate, "simulate a campaign: true motion in, raw IMU samples out", run_simulate);
//
// Exit codes, shared by every subcommand:
//   0  success (and, for commands that judge, PASS)
//   1  the work ran but failed: a singular problem, a rejected table, a FAIL verdict (message on stderr)
//   2  bad input: bad options, or a file the user handed is malformed (one line on stderr naming the
//      file, line or key; nothing written: docs/formats.md "What a bad file gets")
//   3  an external peer failed: Modbus fixture, CAN bus, database
#pragma once

#include <exception>

#include "host/io/input_error.h"

namespace imuforge::app {

using CommandFn = int (*)(int argc, char** argv);

enum ExitCode : int { kExitOk = 0, kExitFailed = 1, kExitUsage = 2, kExitBadInput = 2, kExitPeer = 3 };

// The exit code of a command that stopped on an exception: 2 for bad input (io::is_input_error), else 1.
inline int exit_code_for(const std::exception& e) { return io::is_input_error(e) ? kExitBadInput : kExitFailed; }

struct CommandRegistrar {
  CommandRegistrar(const char* name, const char* summary, CommandFn fn) noexcept;
};

}  // namespace imuforge::app

#define IMUFORGE_COMMAND(name, summary, fn) \
  static const ::imuforge::app::CommandRegistrar imuforge_command_registrar_##name{#name, summary, fn}
