#include "cli/tool.h"

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
      ->check(CLI::NonNegativeNumber)
      ->default_val(0);
  app.add_option("--report", g_report_path, "Write a JSON report of the run (docs/formats.md) to this file");
  app.add_flag("-q,--quiet", g_quiet, "Print errors only");
  app.add_flag("-v,--verbose", g_verbose, "More log output (repeatable)");
  app.allow_extras(false);
  app.get_formatter()->column_width(36);
}

int RunTool(const std::string& tool, CLI::App& app, int argc, char** argv, const std::function<int()>& body) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);  // prints help on stdout, returns 0
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "%s: usage error: %s\nRun '%s --help' for the options.\n", tool.c_str(), e.what(),
                 tool.c_str());
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
    std::fprintf(stderr, "%s: usage error: %s\n", tool.c_str(), e.what());
    return kExitUsage;
  } catch (const Error& e) {
    std::fprintf(stderr, "%s: error: %s\n", tool.c_str(), e.what());
    return kExitFailure;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "%s: error: out of memory\n", tool.c_str());
    return kExitFailure;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", tool.c_str(), e.what());
    return kExitFailure;
  }
}

}  // namespace mr
