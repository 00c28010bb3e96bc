// sweepscan-robotd's configuration file (/etc/sweepscan/robotd.conf when run
// as the packaged service; docs/robot-agent.md "Configuration file"): lines
// `key = value`, where a key is one of robotd's long options without its
// dashes. `#` starts a comment at the start of a line or after a space or
// tab; elsewhere it is part of the value (`name = robot#2`). A value may be
// quoted, "..." or '...' (as systemd's and shell files are written): the
// quotes are removed, and a `#` inside them is the value's. The file's
// settings become command-line options placed before the real ones, so the
// command line overrides the file and both are checked by the same parser;
// each setting keeps its line, so that a bad value is reported as
// FILE:LINE with the key as written.
#ifndef SWEEPSCAN_APP_ROBOTD_CONFIG_H_
#define SWEEPSCAN_APP_ROBOTD_CONFIG_H_

#include <QString>
#include <QStringList>
#include <vector>

namespace sweepscan::app {

struct AgentConfigSetting {
  QString key;  // As written: a long option's name without its dashes.
  QString value;
  int line = 0;  // 1-based.
};

// Reads `path` into its settings, in file order. `keys`: the options a file
// may set (each takes a value). False with "FILE:LINE: why" for a line that
// is not `key = value`, an unknown key, a key given twice, an empty value,
// a quote not closed or followed by more than a comment, or a file that
// cannot be read or is over 64 KiB.
// `warnings` non-null: lenient, for `--stop-motors`, which must find the
// motor port whatever else the file gets wrong: a bad line, an unknown key
// or an empty value is skipped, a key given twice keeps its last value, and
// each is a "FILE:LINE: why" in *warnings; only a file that cannot be read
// fails.
bool ReadAgentConfigFile(const QString& path, const QStringList& keys,
                         std::vector<AgentConfigSetting>* settings, QString* error,
                         QStringList* warnings = nullptr);

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_ROBOTD_CONFIG_H_
