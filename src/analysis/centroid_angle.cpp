#include "analysis/centroid_angle.hpp"
