// doctest main of the lab suite.
#include "test_main.h"
