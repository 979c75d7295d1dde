// doctest main of the front-door (rgs_api) suite.
#include "test_main.h"
