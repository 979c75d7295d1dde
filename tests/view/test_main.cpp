// doctest main of the viewer library (rgs_view) suite.
#include "test_main.h"
