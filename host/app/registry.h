#pragma once
#include "host/app/command.h"

namespace imuforge::app {
struct CommandEntry {
  const char* name;
  const char* summary;
  CommandFn fn;
};
const CommandEntry* commands_begin();
const CommandEntry* commands_end();
}  // namespace imuforge::app
