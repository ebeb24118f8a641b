// A host application driving the surgical pipeline from code: it loads a scene, builds the soft
// body, then each frame gives the body the pose of its probe and of its blade (as a haptic
// device or a tracked instrument would), here a probe that presses the top of the body and a
// blade that sweeps across its middle. It prints the parts and the fragments, and exits non-zero
// unless the body came apart in two large parts.
//
//   cut_host SCENE.json     (a scene with a "simulation" section, e.g. scenes/soft_peanut.json)
#include <blobvk/surgery/soft_body.h>
#include <blobvk/surgery/tet_model.h>

#include <cstdio>
#include <exception>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: cut_host SCENE.json\n");
    return 2;
  }
  try {
    using namespace blobvk;
    const surgery::SceneModel scene = surgery::loadSceneModel(argv[1]);
    const blobtree::GridSpec grid = blobtree::chooseGrid(scene.program, scene.scene.grid, {std::nullopt, 40});
    surgery::TetModel model = surgery::buildTetModel(scene, grid);
    const auto& b = scene.program.bounds;
    const double cx = 0.5 * (b.lo.x + b.hi.x), top = b.hi.y, depth = b.hi.z - b.lo.z;

    surgery::SoftBody body(std::move(model.tets), model.config.settings);
    if (!model.renderTetBoundary) body.setRenderSurface(std::move(model.surface), std::move(model.embedding));
    const std::size_t tools = model.config.settings.tools.size();
    for (int frame = 0; frame < 40; ++frame) {
      surgery::StepInput input;
      // The probe (the scene's first tool, if any) comes down onto the top, off the blade's plane.
      for (std::size_t k = 0; k < tools; ++k) {
        fem::ToolPose pose;
        pose.position = {cx + 0.4 * (b.hi.x - cx), top + 0.1 - 0.004 * frame, 0};
        input.tools.push_back(pose);
      }
      // The blade: a vertical edge through the middle, sweeping from the back to the front over
      // frames 5..25 (outside the body before and after).
      if (frame >= 5 && frame <= 25) {
        const double z = b.lo.z - 0.1 + (depth + 0.2) * (frame - 5) / 20.0;
        input.blade.push_back({{cx + 0.03, b.hi.y + 0.2, z}, {cx + 0.03, b.lo.y - 0.2, z}});
        input.endStroke = frame == 25;
      }
      body.step(input);
    }
    std::size_t total = 0;
    for (const auto& part : body.parts()) total += part.size();
    std::printf("%zu cut events, %zu tets split; parts (tets):", body.events(), body.splitTets());
    for (const auto& part : body.parts()) std::printf(" %zu", part.size());
    std::printf("; %zu fragments\n", body.fragments().size());
    const bool twoHalves = body.parts().size() == 2 && 10 * body.parts()[1].size() >= 3 * total;
    if (!twoHalves) std::fprintf(stderr, "cut_host: the body did not come apart in two large parts\n");
    return twoHalves ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cut_host: %s\n", e.what());
    return 1;
  }
}
