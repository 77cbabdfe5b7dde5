#include "scale_drift_slam/io/key_suggestion.h"

#include <algorithm>
#include <cctype>
#include <limits>

namespace scale_drift_slam::io {
namespace {

std::string lowered(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

}  // namespace

std::size_t editDistance(const std::string& a, const std::string& b) {
  const std::size_t n = a.size(), m = b.size();
  // d[i][j]: distance between the first i characters of a and the first j of b.
  std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1, 0));
  for (std::size_t i = 0; i <= n; ++i)
    d[i][0] = i;
  for (std::size_t j = 0; j <= m; ++j)
    d[0][j] = j;
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[n][m];
}

std::string closestKey(const std::string& key, const std::vector<std::string>& candidates) {
  if (key.size() > 100) return "";  // not a typo of a key; and the distance is quadratic
  const std::string key_lower = lowered(key);
  const std::size_t limit = key.size() <= 4 ? 1 : key.size() / 3;
  std::string best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  for (const std::string& candidate : candidates) {
    if (candidate == key) continue;
    const std::size_t distance =
        lowered(candidate) == key_lower ? 0 : editDistance(key_lower, lowered(candidate));
    if (distance < best_distance) {
      best_distance = distance;
      best = candidate;
    }
  }
  return best_distance <= limit ? best : "";
}

std::string unknownKeyMessage(const std::string& what, const std::string& key,
                              const std::vector<std::string>& candidates) {
  return unknownKeyMessageSuggesting(what, key, closestKey(key, candidates));
}

std::string unknownKeyMessageSuggesting(const std::string& what, const std::string& key,
                                        const std::string& suggestion) {
  return "unknown " + what + " '" + key + "'" +
         (suggestion.empty() ? "" : " (did you mean '" + suggestion + "'?)");
}

}  // namespace scale_drift_slam::io
