// constants.h: constants of the core (internal header).
#pragma once

namespace argand::detail {

constexpr double kPi = 3.14159265358979323846;

}  // namespace argand::detail
