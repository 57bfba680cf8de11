#pragma once
// pi for the host wings that may include only base (the analysis wing): the kernels' constant, so the value is
// written once in the code (kernels/constants.hpp, the lowest floor, which base may include).
#include "kernels/constants.hpp"
