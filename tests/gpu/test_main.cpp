// doctest main of the GPU suite.
#include "test_main.h"
