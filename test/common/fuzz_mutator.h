#pragma once
// FuzzMutator: a seeded random mutator for fuzz tests in gtest (issue 17). Header-only, no
// dependency beyond the standard library, so that any test or benchmark can include it:
//   #include "../common/fuzz_mutator.h"
//   scale_drift_slam::testing::FuzzMutator mutator(/*seed=*/1, {"fx", "distortion_model"});
//   const std::string input = mutator.mutateText(seed_text);   // 1..4 stacked mutations
//   const double value = mutator.mutateDouble(1.5);            // nan, inf, -0, 1e300, x 10^k..
// Text mutations: byte and bit flips, truncation, deletion and duplication of a range, line
// swaps/drops/duplicates, a number replaced by a hostile one (nan, inf, 1e300, -0, huge
// integers, hex, a bare "1e"), a key or word replaced by a dictionary word or swapped with
// another, and insertion of dictionary words or YAML/CSV syntax. The same seed gives the same
// sequence of inputs, so a failure is reproduced by its seed and iteration.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace scale_drift_slam::testing {

class FuzzMutator {
 public:
  explicit FuzzMutator(std::uint64_t seed, std::vector<std::string> dictionary = {})
      : rng_(seed), dictionary_(std::move(dictionary)) {}

  /// 1..max_mutations stacked mutations of `input`.
  std::string mutateText(const std::string& input, int max_mutations = 4) {
    std::string text = input;
    const int count = 1 + static_cast<int>(below(static_cast<std::uint64_t>(max_mutations)));
    for (int i = 0; i < count; ++i)
      text = mutateOnce(text);
    return text;
  }

  /// One text mutation, chosen at random.
  std::string mutateOnce(const std::string& text) {
    switch (below(9)) {
      case 0:
        return flipByte(text);
      case 1:
        return truncate(text);
      case 2:
        return deleteRange(text);
      case 3:
        return duplicateRange(text);
      case 4:
        return mutateLines(text);
      case 5:
      case 6:
        return replaceNumber(text);
      case 7:
        return replaceWord(text);
      default:
        return insertToken(text);
    }
  }

  /// A hostile double: nan, +-inf, -0, 0, 1e300, -1e300, denormals, the largest and smallest.
  double nastyDouble() {
    static const double values[] = {std::numeric_limits<double>::quiet_NaN(),
                                    std::numeric_limits<double>::infinity(),
                                    -std::numeric_limits<double>::infinity(),
                                    -0.0,
                                    0.0,
                                    1e300,
                                    -1e300,
                                    1e-300,
                                    std::numeric_limits<double>::denorm_min(),
                                    std::numeric_limits<double>::max(),
                                    std::numeric_limits<double>::lowest(),
                                    -1.0,
                                    4294967296.0};
    return values[below(sizeof(values) / sizeof(values[0]))];
  }

  /// `value` made hostile (half the time) or scaled by 10^k, negated or nudged.
  double mutateDouble(double value) {
    switch (below(4)) {
      case 0:
      case 1:
        return nastyDouble();
      case 2:
        return value * std::pow(10.0, static_cast<double>(below(41)) - 20.0);
      default:
        return below(2) ? -value : value + (uniform() - 0.5);
    }
  }

  /// A hostile integer of type Int: 0, -1, the extremes, extreme +-1, a random value.
  template <typename Int>
  Int nastyInteger() {
    using Limits = std::numeric_limits<Int>;
    switch (below(6)) {
      case 0:
        return 0;
      case 1:
        return static_cast<Int>(-1);
      case 2:
        return Limits::max();
      case 3:
        return Limits::min();
      case 4:
        return static_cast<Int>(Limits::max() - 1);
      default:
        return static_cast<Int>(rng_());
    }
  }

  /// Uniform in [0, n) (0 when n is 0).
  std::uint64_t below(std::uint64_t n) { return n == 0 ? 0 : rng_() % n; }
  double uniform() { return std::uniform_real_distribution<double>(0.0, 1.0)(rng_); }
  std::mt19937_64& engine() { return rng_; }

 private:
  static bool isNumberChar(char c) {
    return (c >= '0' && c <= '9') || c == '.' || c == '-' || c == '+' || c == 'e' || c == 'E';
  }
  static bool isWordChar(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
  }

  std::string flipByte(std::string text) {
    if (text.empty()) return std::string(1, static_cast<char>(below(256)));
    char& c = text[below(text.size())];
    c = below(2) ? static_cast<char>(c ^ (1 << below(8))) : static_cast<char>(below(256));
    return text;
  }

  std::string truncate(const std::string& text) { return text.substr(0, below(text.size() + 1)); }

  std::pair<std::size_t, std::size_t> range(const std::string& text) {
    const std::size_t begin = below(text.size() + 1);
    const std::size_t length = below(std::min<std::size_t>(text.size() - begin, 64) + 1);
    return {begin, length};
  }

  std::string deleteRange(std::string text) {
    const auto [begin, length] = range(text);
    return text.erase(begin, length);
  }

  std::string duplicateRange(std::string text) {
    const auto [begin, length] = range(text);
    const std::string copy = text.substr(begin, length);
    return text.insert(below(text.size() + 1), copy);
  }

  std::vector<std::string> lines(const std::string& text) {
    std::vector<std::string> result;
    std::size_t start = 0;
    while (start <= text.size()) {
      const std::size_t end = text.find('\n', start);
      if (end == std::string::npos) {
        result.push_back(text.substr(start));
        break;
      }
      result.push_back(text.substr(start, end - start));
      start = end + 1;
    }
    return result;
  }

  /// Swaps, drops or duplicates a line.
  std::string mutateLines(const std::string& text) {
    std::vector<std::string> all = lines(text);
    if (all.empty()) return text;
    const std::size_t a = below(all.size()), b = below(all.size());
    switch (below(3)) {
      case 0:
        std::swap(all[a], all[b]);
        break;
      case 1:
        all.erase(all.begin() + static_cast<std::ptrdiff_t>(a));
        break;
      default:
        all.insert(all.begin() + static_cast<std::ptrdiff_t>(a), all[b]);
    }
    std::string joined;
    for (std::size_t i = 0; i < all.size(); ++i)
      joined += (i ? "\n" : "") + all[i];
    return joined;
  }

  /// Positions [begin, end) of the tokens made of `is_part` characters.
  template <typename Predicate>
  std::vector<std::pair<std::size_t, std::size_t>> tokens(const std::string& text,
                                                          Predicate is_part) {
    std::vector<std::pair<std::size_t, std::size_t>> found;
    for (std::size_t i = 0; i < text.size();) {
      if (!is_part(text[i])) {
        ++i;
        continue;
      }
      std::size_t j = i;
      while (j < text.size() && is_part(text[j]))
        ++j;
      found.emplace_back(i, j);
      i = j;
    }
    return found;
  }

  std::string replaceNumber(std::string text) {
    static const char* const hostile[] = {
        "nan",        ".nan",        "NaN",        "inf",
        "-inf",       ".inf",        "-.inf",      "1e300",
        "-1e300",     "-0",          "0",          "1e-300",
        "-1",         "1e",          "4294967296", "99999999999999999999",
        "0x10",       "1.5.5",       "",           "+",
        "2147483648", "-2147483649", "1e308",      "1e309"};
    auto numbers = tokens(text, isNumberChar);
    if (numbers.empty()) return insertToken(text);
    const auto [begin, end] = numbers[below(numbers.size())];
    std::string replacement = hostile[below(sizeof(hostile) / sizeof(hostile[0]))];
    if (below(3) == 0) {  // or the number scaled by a power of ten
      replacement = text.substr(begin, end - begin) + "e" + std::to_string(int(below(41)) - 20);
    }
    return text.replace(begin, end - begin, replacement);
  }

  std::string replaceWord(std::string text) {
    auto words = tokens(text, isWordChar);
    if (words.empty()) return insertToken(text);
    const auto [begin, end] = words[below(words.size())];
    if (!dictionary_.empty() && below(2)) {
      return text.replace(begin, end - begin, dictionary_[below(dictionary_.size())]);
    }
    const auto [other_begin, other_end] = words[below(words.size())];  // swap two words
    const std::string first = text.substr(begin, end - begin);
    const std::string second = text.substr(other_begin, other_end - other_begin);
    if (begin == other_begin) return text;
    if (begin < other_begin) {
      text.replace(other_begin, other_end - other_begin, first);
      return text.replace(begin, end - begin, second);
    }
    text.replace(begin, end - begin, second);
    return text.replace(other_begin, other_end - other_begin, first);
  }

  std::string insertToken(std::string text) {
    static const char* const syntax[] = {
        "\n",  ":",  ": ",        "[",  "]",   "{", "}",  "- ", "\t",          "#",    ",",
        "&a ", "*a", "!!binary ", "? ", "|\n", "'", "\"", "\\", "%YAML:1.0\n", "\r\n", " "};
    std::string token;
    if (!dictionary_.empty() && below(2)) {
      token = dictionary_[below(dictionary_.size())] + (below(2) ? ": " : "");
    } else if (below(8) == 0) {
      token = std::string(1, '\0');
    } else {
      token = syntax[below(sizeof(syntax) / sizeof(syntax[0]))];
    }
    return text.insert(below(text.size() + 1), token);
  }

  std::mt19937_64 rng_;
  std::vector<std::string> dictionary_;
};

}  // namespace scale_drift_slam::testing
