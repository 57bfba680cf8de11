// toml++'s implementation, compiled once for the whole program (TOML_HEADER_ONLY=0 everywhere, see CMakeLists.txt)
// rather than linked from Debian's shared library: that library is built with TOML_FLOAT_CHARCONV=0 and writes
// floats with 17 digits, where std::to_chars gives the shortest text that reads back to the same double
// (to_toml's output: 0.1, not 0.10000000000000001). Floats are parsed with std::from_chars, correctly rounded like
// the strtod path it replaces.
#define TOML_IMPLEMENTATION
#include <toml++/toml.h>
