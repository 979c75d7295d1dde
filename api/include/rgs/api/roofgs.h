// The RoofGS front door in one include: convert files (convert.h), load a scene (scene.h), build a camera
// (camera.h; GLM overloads in camera_glm.h), render it with a preset (preset.h) into your own memory
// (renderer.h).
//
//   auto scene = rgs::api::load("scene.rgs");                       // GPU, fastest preset
//   auto renderer = rgs::api::Renderer::create();
//   auto camera = rgs::api::camera_from_opengl(view, projection, 1920, 1080);
//   renderer->render(*scene, *camera, {}, target, stream);          // target: your device pointer + pitch
//
// docs/EMBEDDING.md has the complete examples (compiled and run by the tests).
#pragma once

#include "rgs/api/camera.h"
#include "rgs/api/convert.h"
#include "rgs/api/scene.h"
#include "rgs/api/preset.h"
#include "rgs/api/renderer.h"
#include "rgs/config.h"
