// doctest main of the lab GPU suite.
#include "test_main.h"
