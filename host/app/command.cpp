#include "host/app/command.h"

#include <array>
#include <cstddef>

#include "host/app/registry.h"

namespace imuforge::app {

namespace {
// A fixed array: registration runs during static initialisation, before any allocator policy matters,
// and the number of subcommands is small and known.
std::array<CommandEntry, 64> g_entries{};
std::size_t g_count = 0;
}  // namespace

CommandRegistrar::CommandRegistrar(const char* name, const char* summary, CommandFn fn) noexcept {
  if (g_count < g_entries.size()) g_entries[g_count++] = CommandEntry{name, summary, fn};
}

const CommandEntry* commands_begin() { return g_entries.data(); }
const CommandEntry* commands_end() { return g_entries.data() + g_count; }

}  // namespace imuforge::app
