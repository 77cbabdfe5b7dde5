#pragma once
// "Did you mean ...?" for the file parsers: an unknown key is named with the closest accepted
// one, so that a misspelt key (`distortion_modle`) is an error that says how to fix it rather
// than a setting silently ignored. One helper for every parser (calibration, parameters).

#include <string>
#include <vector>

namespace scale_drift_slam::io {

/// Optimal string alignment distance: insertions, deletions, substitutions and transpositions of
/// two adjacent characters each count 1 ("modle" -> "model" is 1). Case-sensitive.
std::size_t editDistance(const std::string& a, const std::string& b);

/// The candidate closest to `key` when it is near enough to be a likely typo (at most 1 edit for
/// keys of up to 4 characters, else at most a third of the key's length, or `key` is a
/// case-insensitive match); "" when none is.
std::string closestKey(const std::string& key, const std::vector<std::string>& candidates);

/// "unknown <what> 'key'" followed by " (did you mean 'x'?)" when closestKey finds one.
std::string unknownKeyMessage(const std::string& what, const std::string& key,
                              const std::vector<std::string>& candidates);
/// The same with the suggestion chosen by the caller ("" for none).
std::string unknownKeyMessageSuggesting(const std::string& what, const std::string& key,
                                        const std::string& suggestion);

}  // namespace scale_drift_slam::io
