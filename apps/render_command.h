// `blobvk render`: a scene to PNG, by rasterizing its mesh or ray-casting its field (vk/render*,
// vk/render/raycast*). Registered by main.cpp next to the commands of commands.h.
#pragma once

namespace CLI {
class App;
}

namespace blobvk::app {

void addRenderCommand(CLI::App& app);

}  // namespace blobvk::app
