// Numbers as people read them in reports and labels.
#pragma once

#include <cstdint>
#include <string>

namespace apo {

// 1234567 -> "1,234,567".
std::string groupedDigits(std::uint64_t n);

}  // namespace apo
