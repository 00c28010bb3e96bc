#include "app/robotd_config.h"

#include <QFile>
#include <QSet>

namespace sweepscan::app {

namespace {

// Where a comment starts, from `from` on: a `#` at the start of the line or
// after a space or tab, as in systemd's and most ini files' values. A `#`
// anywhere was taken for one, so `name = robot#2` became `robot` without a
// word.
int CommentStart(const QString& line, int from = 0) {
  for (int i = from; i < line.size(); ++i) {
    if (line[i] == QLatin1Char('#') &&
        (i == 0 || line[i - 1] == QLatin1Char(' ') || line[i - 1] == QLatin1Char('\t'))) {
      return i;
    }
  }
  return -1;
}

bool IsQuote(QChar c) { return c == QLatin1Char('"') || c == QLatin1Char('\''); }

// The value after the `=` at `equals`: as written, trimmed, up to a comment;
// or, when it starts with a quote (" or '), what is between that quote and
// the next one of the same kind, as systemd's and shell files are written
// (`lidar = "/dev/ttyUSB0"`): a `#` inside the quotes is part of the value,
// and after the closing quote only spaces and a comment may follow. Until
// 2026-11-29 the quotes were kept, so a quoted port was opened by a name
// with quotes in it, and failed. False with why for an unclosed quote or
// text after the closing one.
bool ValueAfter(const QString& line, int equals, QString* value, QString* why) {
  int start = equals + 1;
  while (start < line.size() && line[start].isSpace()) ++start;
  if (start < line.size() && IsQuote(line[start])) {
    const QChar quote = line[start];
    const int end = line.indexOf(quote, start + 1);
    if (end < 0) {
      *why =
          QStringLiteral("the value's %1 is not closed (quote it whole, or not at all)").arg(quote);
      return false;
    }
    QString after = line.mid(end + 1);
    const int comment = CommentStart(line, end + 1);
    if (comment >= 0) after = line.mid(end + 1, comment - end - 1);
    if (!after.trimmed().isEmpty()) {
      *why = QStringLiteral("text after the value's closing %1: '%2'").arg(quote, after.trimmed());
      return false;
    }
    *value = line.mid(start + 1, end - start - 1);
    return true;
  }
  const int comment = CommentStart(line, start);
  *value = line.mid(start, comment < 0 ? -1 : comment - start).trimmed();
  return true;
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
    const QString line = QString::fromUtf8(lines[i]);
    const int hash = CommentStart(line);
    const int equals = line.indexOf(QLatin1Char('='));
    if (equals < 0 || (hash >= 0 && hash < equals)) {
      const QString text = line.left(hash).trimmed();
      if (text.isEmpty()) continue;  // Blank, or a comment.
      if (!fail(QStringLiteral("expected 'key = value', got '%1'").arg(text))) return false;
      continue;
    }
    const QString key = line.left(equals).trimmed();
    QString value, why;
    if (!ValueAfter(line, equals, &value, &why)) {
      if (!fail(QStringLiteral("'%1': %2").arg(key, why))) return false;
      continue;
    }
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
