// doctest main of the fork-join (rgs_parallel) suite.
#include "test_main.h"
