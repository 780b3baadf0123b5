// dynamap: the one header a user includes. Pipeline (depth + pose in, static map, tracked
// obstacles and predicted paths out), its configuration and named parameters, and Runner (the
// pipeline on its own thread behind lock-free rings). Stage headers live in one folder each:
// core/ (status, fixed containers, rings), map/, detect/, track/, predict/, pipeline/.
#pragma once

#include "dynamap/pipeline/parameters.hpp"
#include "dynamap/pipeline/pipeline.hpp"
#include "dynamap/pipeline/pipeline_config.hpp"
#include "dynamap/pipeline/runner.hpp"
