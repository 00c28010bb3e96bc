#include "app/robotd_config.h"

#include <QFile>
#include <QSet>

namespace sweepscan::app {

namespace {

// Where a comment starts: a `#` at the start of the line or after a space
// or tab, as in systemd's and most ini files' values. A `#` anywhere was
// taken for one, so `name = robot#2` became `robot` without a word.
int CommentStart(const QString& line) {
  for (int i = 0; i < line.size(); ++i) {
    if (line[i] == QLatin1Char('#') &&
        (i == 0 || line[i - 1] == QLatin1Char(' ') || line[i - 1] == QLatin1Char('\t'))) {
      return i;
    }
  }
  return -1;
}

}  // namespace

bool ReadAgentConfigFile(const QString& path, const QStringList& keys,
                         std::vector<AgentConfigSetting>* settings, QString* error,
                         QStringList* warnings) {
  constexpr qint64 kMaxBytes = 64 * 1024;  // A configuration, not a data file.
  QFile file(path);
  if (!file.open(QIODevice::ReadOnly)) {
    *error = QStringLiteral("config file %1: %2").arg(path, file.errorString());
    return false;
  }
  const QByteArray bytes = file.read(kMaxBytes + 1);
  if (bytes.size() > kMaxBytes) {
    *error = QStringLiteral("config file %1 is over %2 bytes").arg(path).arg(kMaxBytes);
    return false;
  }
  QSet<QString> seen;
  const QList<QByteArray> lines = bytes.split('\n');
  for (int i = 0; i < lines.size(); ++i) {
    bool skip = false;
    const auto fail = [&](const QString& why) {
      const QString where = QStringLiteral("%1:%2: %3").arg(path).arg(i + 1).arg(why);
      if (warnings == nullptr) {
        *error = where;
        return false;
      }
      warnings->push_back(where);
      skip = true;
      return true;
    };
    QString line = QString::fromUtf8(lines[i]);
    const int hash = CommentStart(line);
    if (hash >= 0) line.truncate(hash);
    line = line.trimmed();
    if (line.isEmpty()) continue;
    const int equals = line.indexOf(QLatin1Char('='));
    if (equals < 0) {
      if (!fail(QStringLiteral("expected 'key = value', got '%1'").arg(line))) return false;
      continue;
    }
    const QString key = line.left(equals).trimmed();
    const QString value = line.mid(equals + 1).trimmed();
    if (!keys.contains(key)) {
      if (!fail(QStringLiteral("unknown key '%1' (keys: %2)").arg(key, keys.join(QStringLiteral(", ")))))
        return false;
    } else if (value.isEmpty()) {
      if (!fail(QStringLiteral("'%1' has no value").arg(key))) return false;
    } else if (seen.contains(key)) {
      if (!fail(QStringLiteral("'%1' is set twice; the last one is used").arg(key))) return false;
      // Lenient: the last value wins, as in systemd's files.
      for (AgentConfigSetting& earlier : *settings) {
        if (earlier.key == key) earlier = {key, value, i + 1};
      }
      continue;
    }
    if (skip) continue;
    seen.insert(key);
    settings->push_back({key, value, i + 1});
  }
  return true;
}

}  // namespace sweepscan::app
