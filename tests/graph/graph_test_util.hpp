// Small helpers shared by the graph suites (plain header: included before any import).
#pragma once
#include <algorithm>
#include <string>
#include <vector>

namespace graph_test {

inline bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

inline bool has(const std::vector<std::string>& list, const std::string& item) {
  return std::find(list.begin(), list.end(), item) != list.end();
}

}  // namespace graph_test
