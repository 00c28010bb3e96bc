// Shared by the two agent executables (sweepscan-robotd, sweepscan-sim).
#ifndef SWEEPSCAN_APP_AGENT_MAIN_COMMON_H_
#define SWEEPSCAN_APP_AGENT_MAIN_COMMON_H_

#include <QCommandLineOption>
#include <QCommandLineParser>
#include <QCoreApplication>
#include <QHostAddress>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <functional>
#include <tuple>

#include "app/quit_on_signal.h"
#include "hardware/agent/robot_agent.h"
#include "hardware/link/qt_transport.h"

namespace sweepscan::app {

// The options both agents take: the TCP listen address, the key file, the
// watchdog and the motion limits. Add() registers them; Apply() reads them
// into the configuration (TCP unless `tcp` is false, e.g. for a serial or
// pty link, which has no authentication).
struct AgentCommandLine {
  QCommandLineOption listen{QStringLiteral("listen"),
                            "Serve the link on TCP ADDR:PORT (default 127.0.0.1:5600; port 0 = "
                            "any free port).",
                            "ADDR:PORT"};
  QCommandLineOption key_file{QStringLiteral("key-file"), "Pre-shared key file (required for TCP).",
                              "FILE"};
  QCommandLineOption watchdog{QStringLiteral("watchdog-ms"),
                              "Watchdog period in ms, 100..5000 (default 500).", "MS"};
  QCommandLineOption v_max{QStringLiteral("v-max"), "Speed limit in m/s (default 0.5).", "MPS"};
  QCommandLineOption w_max{QStringLiteral("w-max"), "Turn rate limit in rad/s (default 1.5).",
                           "RADPS"};
  QCommandLineOption accel{QStringLiteral("accel-max"),
                           "Acceleration limit in m/s^2 (default 1.0).", "MPS2"};
  QCommandLineOption alpha{QStringLiteral("alpha-max"),
                           "Angular acceleration limit in rad/s^2 (default 3.0).", "RADPS2"};
  QCommandLineOption buffer{QStringLiteral("buffer-s"),
                            "Keep the last S seconds of device bytes, 0..60 (default 10), and "
                            "resend them to a workstation that reconnects after an outage.",
                            "S"};
  QCommandLineOption lidar_idle{
      QStringLiteral("lidar-idle-s"),
      "Turn the lidar's motor off after S seconds without a client; 0 = never (default: "
      "buffer-s + 20, 30 s; at least buffer-s + 5, so a returning workstation finds the "
      "lidar's bytes of its outage).",
      "S"};

  // Where a value that did not come from the command line came from, for
  // its messages: e.g. "robotd.conf:7: v-max" for the option named "v-max"
  // (robotd's configuration file); empty for the command line's own.
  std::function<QString(const QString& name)> origin;

  void Add(QCommandLineParser* parser) const {
    parser->addOptions({listen, key_file, watchdog, v_max, w_max, accel, alpha, buffer, lidar_idle});
  }

  // The subject of a message about `option`'s value: "--v-max", or where
  // the file set it ("robotd.conf:7: v-max").
  QString Subject(const QCommandLineOption& option) const {
    const QString name = option.names().first();
    const QString where = origin ? origin(name) : QString();
    return where.isEmpty() ? QStringLiteral("--") + name : where;
  }
  // `message` (which names the value itself, e.g. a key file's path),
  // prefixed with where the file set the option; as is for the command line.
  QString Located(const QCommandLineOption& option, const QString& message) const {
    const QString where = origin ? origin(option.names().first()) : QString();
    return where.isEmpty() ? message : where + QStringLiteral(": ") + message;
  }

  // `key_permissions`: what to do with a key file others may read
  // (sweepscan-robotd refuses it, sweepscan-sim warns).
  bool Apply(const QCommandLineParser& parser, bool tcp, hardware::RobotAgentConfig* config,
             QString* error,
             hardware::KeyFilePermissions key_permissions =
                 hardware::KeyFilePermissions::kOwnerOnly) const {
    if (tcp) {
      hardware::LinkAddress address;
      const QString text =
          parser.isSet(listen) ? parser.value(listen) : QStringLiteral("127.0.0.1:5600");
      if (!hardware::ParseLinkAddress(text, &address, error)) {
        *error = Located(listen, *error);
        return false;
      }
      if (address.kind != hardware::LinkAddress::Kind::kTcp) {
        *error = Subject(listen) + QStringLiteral(" expects ADDR:PORT, got '%1'").arg(text);
        return false;
      }
      if (QHostAddress(address.host).isNull()) {
        *error = Subject(listen) + QStringLiteral(": '%1' is not an IP address").arg(address.host);
        return false;
      }
      config->listen_address = address.host;
      config->listen_port = address.port;
      if (!parser.isSet(key_file)) {
        *error = QStringLiteral("--key-file is required on TCP (clients authenticate with it)");
        return false;
      }
    }
    if (parser.isSet(key_file) && !tcp) {
      // The serial link carries no authentication (protocol.md, "Connection,
      // authentication"): the key is not read. The packaged file's `key-file`
      // stays when `--serial` replaces its `listen`, and a missing key
      // file used to stop the agent there; on the command line it is a
      // mistake, refused as `sweepscan record` refuses it.
      // The simulator (a test and demo tool, whose --pty is its serial
      // link) only says so, as it only warns about a key others may read.
      const QString where = origin ? origin(key_file.names().first()) : QString();
      if (where.isEmpty() && key_permissions == hardware::KeyFilePermissions::kOwnerOnly) {
        *error = QStringLiteral(
            "--key-file does not apply to the serial link (it has no "
            "authentication)");
        return false;
      }
      std::fprintf(stderr, "note: %s: not used on the serial link (it has no authentication)\n",
                   qPrintable(where.isEmpty() ? QStringLiteral("--key-file") : where));
    } else if (parser.isSet(key_file)) {
      QString warning;
      if (!hardware::ReadKeyFile(parser.value(key_file), &config->agent.key, error,
                                 key_permissions, &warning)) {
        *error = Located(key_file, *error);
        return false;
      }
      if (!warning.isEmpty()) std::fprintf(stderr, "warning: %s\n", qPrintable(warning));
    }
    double watchdog_ms = 0.0;
    double buffer_s = ToSeconds(config->agent.telemetry_buffer);
    if (!Number(parser, buffer, &buffer_s, error) ||
        !Number(parser, watchdog, &watchdog_ms, error) ||
        !Number(parser, v_max, &config->agent.v_max_mps, error) ||
        !Number(parser, w_max, &config->agent.w_max_radps, error) ||
        !Number(parser, accel, &config->agent.accel_max_mps2, error) ||
        !Number(parser, alpha, &config->agent.alpha_max_radps2, error)) {
      return false;
    }
    if (parser.isSet(watchdog)) {
      // Bounded: 1e9 used to be accepted, which switched the watchdog off.
      if (!(watchdog_ms >= 100.0 && watchdog_ms <= 5000.0)) {
        *error = Subject(watchdog) +
                 QStringLiteral(" must be within 100..5000, got %1").arg(parser.value(watchdog));
        return false;
      }
      config->agent.watchdog = FromSeconds(watchdog_ms * 1e-3);
    }
    if (!(buffer_s >= 0.0 && buffer_s <= 60.0)) {
      *error = Subject(buffer) +
               QStringLiteral(" must be within 0..60, got %1").arg(parser.value(buffer));
      return false;
    }
    // The limits checked here, by name (AgentOptions::IsValid would say
    // "v_max must be ...", naming neither the option nor the file's line).
    // The motor board's wire format saturates at 32.767 m/s and rad/s.
    for (const auto& [option, value, max] :
         {std::tuple{&v_max, config->agent.v_max_mps, 32.0},
          std::tuple{&w_max, config->agent.w_max_radps, 32.0},
          std::tuple{&accel, config->agent.accel_max_mps2, HUGE_VAL},
          std::tuple{&alpha, config->agent.alpha_max_radps2, HUGE_VAL}}) {
      if (!(value > 0.0 && value <= max && std::isfinite(value))) {
        *error = Subject(*option) +
                 (max < HUGE_VAL ? QStringLiteral(" must be within (0, %1]").arg(max)
                                 : QStringLiteral(" must be positive and finite")) +
                 QStringLiteral(", got %1").arg(parser.value(*option));
        return false;
      }
    }
    config->agent.telemetry_buffer = FromSeconds(buffer_s);
    // Long enough that a workstation back within the buffer's time (plus
    // the agent's wait for its resume) is resent the lidar's bytes too.
    const double least_idle_s = buffer_s + ToSeconds(config->agent.resume_wait);
    double idle_s = std::max(30.0, buffer_s + 20.0);
    if (!Number(parser, lidar_idle, &idle_s, error)) return false;
    if (!(idle_s == 0.0 || (idle_s >= least_idle_s && idle_s <= 86400.0))) {
      *error = Subject(lidar_idle) +
               QStringLiteral(" must be 0 (never) or within %1..86400 (buffer-s + %2 s), got %3")
                   .arg(least_idle_s)
                   .arg(ToSeconds(config->agent.resume_wait))
                   .arg(parser.value(lidar_idle));
      return false;
    }
    config->agent.lidar_idle_off = FromSeconds(idle_s);
    return config->IsValid(error);
  }

 private:
  // Leaves *out alone when the option is not given.
  bool Number(const QCommandLineParser& parser, const QCommandLineOption& option, double* out,
              QString* error) const {
    if (!parser.isSet(option)) return true;
    bool ok = false;
    const QString text = parser.value(option);
    const double value = text.toDouble(&ok);
    if (!ok) {
      *error = Subject(option) + QStringLiteral(": '%1' is not a number").arg(text);
      return false;
    }
    *out = value;
    return true;
  }
};

// Logs the agent's messages and client comings and goings on stderr.
inline void LogAgentEvents(hardware::RobotAgent* agent) {
  QObject::connect(agent, &hardware::RobotAgent::logMessage,
                   [](const QString& m) { std::fprintf(stderr, "%s\n", qPrintable(m)); });
  QObject::connect(agent, &hardware::RobotAgent::clientConnected, [](const QString& p) {
    std::fprintf(stderr, "client connected: %s\n", qPrintable(p));
  });
  QObject::connect(agent, &hardware::RobotAgent::clientDisconnected,
                   [](const QString& p, const QString& r) {
                     std::fprintf(stderr, "client %s gone: %s\n", qPrintable(p), qPrintable(r));
                   });
}

// Runs the event loop until one of kQuitSignals (SIGINT, SIGTERM, SIGHUP,
// SIGQUIT), then shuts the agent down through the loop (a self-pipe wakes
// it), so the motors get their zero command before the process exits. The
// handlers are installed here unless the caller did it earlier (robotd
// does, before the agent starts).
inline int RunAgentUntilSignal(QCoreApplication* app, hardware::RobotAgent* agent) {
  QuitOnSignals(app);
  const int rc = app->exec();
  agent->Shutdown();
  return rc;
}

// Nothing escapes an agent's main: an exception becomes one line and exit 1
// (options errors are exit 2 with their own line, before the agent starts).
inline int RunAgentMain(const char* program, int (*agent_main)(int, char**), int argc,
                        char** argv) {
  try {
    return agent_main(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: unexpected failure: %s\n", program, e.what());
  } catch (...) {
    std::fprintf(stderr, "%s: error: unexpected failure\n", program);
  }
  return 1;
}

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_AGENT_MAIN_COMMON_H_
