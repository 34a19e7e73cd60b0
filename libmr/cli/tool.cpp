#include "cli/tool.h"

#include <malloc.h>

#include <cmath>
#include <csignal>
#include <cstdio>

#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/parallel.h"
#include "core/version.h"

namespace mr {

std::string JoinCommandLine(int argc, char** argv) {
  std::string s;
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i];
    bool plain = !a.empty() && a.find_first_of(" \t\n'\"\\$`*?[]{}()<>|&;#~") == std::string::npos;
    if (!plain) {
      std::string q = "'";
      for (char c : a) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
      a = q + "'";
    }
    s += (i ? " " : "") + a;
  }
  return s;
}

std::string PrintableMessage(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  size_t i = 0;
  while (i < s.size()) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    // The length of a well-formed UTF-8 sequence starting here, or 0.
    size_t n = 0;
    if (c >= 0x20 && c < 0x7f)
      n = 1;
    else if (c == '\n' || c == '\t')
      n = 1;
    else if (c >= 0xc2 && c <= 0xdf)
      n = 2;
    else if (c >= 0xe0 && c <= 0xef)
      n = 3;
    else if (c >= 0xf0 && c <= 0xf4)
      n = 4;
    bool ok = n > 0 && i + n <= s.size();
    for (size_t k = 1; ok && k < n; ++k) ok = (static_cast<unsigned char>(s[i + k]) & 0xc0) == 0x80;
    if (ok && n == 3) {  // no overlong forms or surrogates
      const unsigned char c1 = static_cast<unsigned char>(s[i + 1]);
      ok = !(c == 0xe0 && c1 < 0xa0) && !(c == 0xed && c1 >= 0xa0);
    }
    if (ok && n == 4) {
      const unsigned char c1 = static_cast<unsigned char>(s[i + 1]);
      ok = !(c == 0xf0 && c1 < 0x90) && !(c == 0xf4 && c1 >= 0x90);
    }
    if (ok) {
      out.append(s.substr(i, n));
      i += n;
    } else {
      out += fmt::format("\\x{:02x}", c);
      ++i;
    }
  }
  return out;
}

namespace {

CLI::Validator NumberCheck(const std::string& name, std::function<std::string(double)> check) {
  return CLI::Validator(
      [check](std::string& input) -> std::string {
        double v = 0;
        if (!CLI::detail::lexical_cast(input, v) || !std::isfinite(v))
          return fmt::format("\"{}\" is not a number", input);
        std::string why = check(v);
        return why.empty() ? why : fmt::format("{} {}", input, why);
      },
      name);
}

}  // namespace

const CLI::Validator kPositive =
    NumberCheck("POSITIVE", [](double v) { return v > 0 ? std::string() : std::string("must be greater than 0"); });
const CLI::Validator kNonNegative =
    NumberCheck("NONNEGATIVE", [](double v) { return v >= 0 ? std::string() : std::string("must be 0 or more"); });

CLI::Validator InRange(double lo, double hi) {
  return NumberCheck(fmt::format("{}..{}", lo, hi), [lo, hi](double v) {
    return v >= lo && v <= hi ? std::string() : fmt::format("is outside {}..{}", lo, hi);
  });
}

namespace {
int g_threads = 0;
bool g_quiet = false;
int g_verbose = 0;
std::string g_report_path;
Report g_report;
}  // namespace

Report& ToolReport() { return g_report; }

void ConfigureApp(CLI::App& app, const std::string& tool, const std::string& description, const std::string& example) {
  app.name(tool);
  app.description(description);
  app.footer("Example:\n" + example + "\n\nExit codes: 0 success, 1 failure, 2 usage error.\nmr " +
             std::string(kVersion) + "; docs/tools.md describes every tool.");
  app.set_version_flag("--version", std::string(kVersion));
  app.add_option("--threads", g_threads, "Worker threads (0 = all cores); results do not depend on it")
      ->check(kNonNegative)
      ->default_val(0);
  app.add_option("--report", g_report_path, "Write a JSON report of the run (docs/formats.md) to this file");
  app.add_flag("-q,--quiet", g_quiet, "Print errors only");
  app.add_flag("-v,--verbose", g_verbose, "More log output (repeatable)");
  app.allow_extras(false);
  app.get_formatter()->column_width(36);
}

int RunTool(const std::string& tool, CLI::App& app, int argc, char** argv, const std::function<int()>& body) {
  // A file-size limit (ulimit -f) then fails the write with EFBIG, which the
  // checked writes report and clean up after, instead of killing the tool.
  std::signal(SIGXFSZ, SIG_IGN);
  // Freed memory stays with the process for the next frame: a frame's
  // images (4-22 MB at 640x480) would otherwise be mapped afresh and
  // faulted in page by page each time, a third of a 1-spp frame's wall time
  // (docs/benchmarks.md).  32 MiB is glibc's largest mmap threshold.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);  // prints help on stdout, returns 0
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "%s: usage error: %s\nRun '%s --help' for the options.\n", tool.c_str(),
                 PrintableMessage(e.what()).c_str(), tool.c_str());
    return kExitUsage;
  }
  spdlog::set_pattern("%n: %l: %v");
  spdlog::set_level(g_quiet ? spdlog::level::err
                            : (g_verbose >= 2 ? spdlog::level::trace
                                              : (g_verbose == 1 ? spdlog::level::debug : spdlog::level::info)));
  spdlog::default_logger()->set_pattern(tool + ": %l: %v");
  SetThreadCount(g_threads);
  g_report = Report(tool, JoinCommandLine(argc, argv));
  try {
    int rc;
    {
      ScopedTimer total(&g_report, "total");
      rc = body();
    }
    g_report.SetMetric("exit_code", rc);
    if (!g_report_path.empty()) g_report.Write(g_report_path);
    return rc;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "%s: usage error: %s\n", tool.c_str(), PrintableMessage(e.what()).c_str());
    return kExitUsage;
  } catch (const Error& e) {
    std::fprintf(stderr, "%s: error: %s\n", tool.c_str(), PrintableMessage(e.what()).c_str());
    return kExitFailure;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "%s: error: out of memory\n", tool.c_str());
    return kExitFailure;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", tool.c_str(), PrintableMessage(e.what()).c_str());
    return kExitFailure;
  }
}

}  // namespace mr
