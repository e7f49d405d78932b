// imuforge: the factory-side program. `imuforge <command> --help` documents each command.
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

#include "host/app/registry.h"

using imuforge::app::CommandEntry;

static void usage(FILE* out) {
  std::fprintf(out, "imuforge %s: factory IMU calibration\n\nusage: imuforge <command> [options]\n\ncommands:\n",
               IMUFORGE_VERSION);
  std::vector<const CommandEntry*> sorted;
  for (auto* e = imuforge::app::commands_begin(); e != imuforge::app::commands_end(); ++e) sorted.push_back(e);
  std::sort(sorted.begin(), sorted.end(),
            [](const CommandEntry* a, const CommandEntry* b) { return std::strcmp(a->name, b->name) < 0; });
  for (auto* e : sorted) std::fprintf(out, "  %-14s %s\n", e->name, e->summary);
  std::fprintf(out, "\n`imuforge <command> --help` for the options of one command.\n");
}

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "help")) {
    usage(argc < 2 ? stderr : stdout);
    return argc < 2 ? imuforge::app::kExitUsage : imuforge::app::kExitOk;
  }
  if (!std::strcmp(argv[1], "--version")) {
    std::printf("imuforge %s\n", IMUFORGE_VERSION);
    return 0;
  }
  for (auto* e = imuforge::app::commands_begin(); e != imuforge::app::commands_end(); ++e) {
    if (std::strcmp(e->name, argv[1]) != 0) continue;
    std::string prog = std::string("imuforge ") + e->name;
    std::vector<char*> args;
    args.push_back(prog.data());
    for (int i = 2; i < argc; ++i) args.push_back(argv[i]);
    try {
      return e->fn(static_cast<int>(args.size()), args.data());
    } catch (const std::exception& ex) {
      std::fprintf(stderr, "imuforge %s: error: %s\n", e->name, ex.what());
      return imuforge::app::exit_code_for(ex);
    }
  }
  std::fprintf(stderr, "imuforge: unknown command '%s'\n\n", argv[1]);
  usage(stderr);
  return imuforge::app::kExitUsage;
}
