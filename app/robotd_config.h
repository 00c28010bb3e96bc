// sweepscan-robotd's configuration file (/etc/sweepscan/robotd.conf when run
// as the packaged service; docs/robot-agent.md "Configuration file"): lines
// `key = value`, where a key is one of robotd's long options without its
// dashes, `#` starts a comment. The file's settings become command-line
// options placed before the real ones, so the command line overrides the
// file and both are checked by the same parser with the same messages.
#ifndef SWEEPSCAN_APP_ROBOTD_CONFIG_H_
#define SWEEPSCAN_APP_ROBOTD_CONFIG_H_

#include <QString>
#include <QStringList>

namespace sweepscan::app {

// Reads `path` into `--key value` pairs appended to *args. `keys`: the
// options a file may set (each takes a value). False with "FILE:LINE: why"
// for a line that is not `key = value`, an unknown key, a key given twice,
// an empty value, or a file that cannot be read or is over 64 KiB.
bool ReadAgentConfigFile(const QString& path, const QStringList& keys, QStringList* args,
                         QString* error);

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_ROBOTD_CONFIG_H_
