#pragma once
// What every fuzz target defines (libFuzzer's entry points), and what the
// targets share: a scratch directory that lives as long as the process.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);
// Optional: run once before the first input (libFuzzer, and replay_main.cpp).
extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv);

namespace psrig::fuzz {

// A fresh directory under /dev/shm (else $TMPDIR or /tmp), removed at exit.
std::filesystem::path scratch_directory();

// Writes `size` bytes to `file` (replacing it); aborts if it cannot.
void write_file(const std::filesystem::path& file, const std::uint8_t* data, std::size_t size);
void write_file(const std::filesystem::path& file, std::string_view text);

// A port on 127.0.0.1 free at the time of asking (for servers that cannot
// be told port 0 and asked which they got).
int free_loopback_port();

// One TCP connection to 127.0.0.1:`port`: writes the bytes, waits up to
// `answer_window_ms` for an answer to begin, shuts the writing side (the
// server sees the end of the input: a request cut short ends there), reads
// until the server closes or `deadline_ms` passes, and resets the
// connection (no TIME_WAIT left behind, so a long run does not use up the
// ports). Gives what was read; `stop_after` non-empty: stop reading once it
// has been seen before the first blank line (an event stream's head; the
// stream never ends).
// PSRIG_FUZZ_VERBOSE set: each exchange is summed up on stderr.
std::string exchange(int port, const std::uint8_t* data, std::size_t size, int deadline_ms,
                     int answer_window_ms = 0, std::string_view stop_after = {});

// Every psrig log category off: the targets feed garbage on purpose.
void quiet_logs();

}  // namespace psrig::fuzz
