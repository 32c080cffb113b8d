// Logging sink. Penumbra is silent unless the host installs a sink: the library never prints on
// its own. The command-line tool and the editor install one; tests may install one to capture.
#pragma once

#include <functional>
#include <string_view>

namespace penumbra {

enum class LogLevel { Debug, Info, Warning, Error };

const char* to_string(LogLevel level);

using LogSink = std::function<void(LogLevel level, std::string_view message)>;

// Installs the process-wide sink (thread-safe); an empty function restores silence.
void set_log_sink(LogSink sink);

// Messages below this level are dropped before formatting reaches the sink (default Info).
void set_log_level(LogLevel min_level);

// Sends one message to the sink, if any. Thread-safe; messages are never interleaved.
void log(LogLevel level, std::string_view message);

}  // namespace penumbra
