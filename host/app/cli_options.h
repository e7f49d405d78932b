// CLI options that several subcommands share, so they are spelled and checked the same everywhere.
#pragma once

#include <iterator>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "host/io/log.h"

namespace imuforge::app {

// --log-format auto|csv|bin|h5 (io::encoding_from_name turns the value into an io::LogEncoding).
inline CLI::Option* add_log_format_option(CLI::App& app, std::string& format, const std::string& names = "--log-format") {
  return app.add_option(names, format, "auto (from the output's extension)|csv|bin|h5")
      ->check(CLI::IsMember(std::vector<std::string>(std::begin(io::kLogFormatNames), std::end(io::kLogFormatNames))));
}

}  // namespace imuforge::app
