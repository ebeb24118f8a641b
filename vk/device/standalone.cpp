// Links libvulkan for the loader entry point only; everything else goes through Dispatch.
#include "blobvk/vk/device/standalone.h"

#include "blobvk/vk/device/error.h"
#include "blobvk/vk/device/pipeline_cache_file.h"

#include <vulkan/vulkan.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdlib>
#include <cstdio>
#include <string>
#include <cstring>
#include <mutex>
#include <set>

namespace blobvk::vk {

struct StandaloneContext::Counters {
  std::atomic<std::uint32_t> messages{0};
  bool print = true;
  std::mutex mutex;  // the layer may call back from any thread
  std::string lastId;
};

namespace {

// Several contexts of one device (`--devices 0,0`) share its cache file: a warning about it is
// printed by the first alone.
void warnOncePerProcess(const std::string& key, const std::string& line) {
  static std::mutex mutex;
  static std::set<std::string> warned;
  const std::lock_guard<std::mutex> lock(mutex);
  if (warned.insert(key).second) std::fprintf(stderr, "%s\n", line.c_str());
}

const char* kNoDevice =
    "no Vulkan device found: install mesa-vulkan-drivers (lavapipe) or a GPU driver, and check "
    "VK_ICD_FILENAMES";

VKAPI_ATTR VkBool32 VKAPI_CALL onMessage(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                         VkDebugUtilsMessageTypeFlagsEXT,
                                         const VkDebugUtilsMessengerCallbackDataEXT* data,
                                         void* user) {
  auto* counters = static_cast<StandaloneContext::Counters*>(user);
  if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
    // The loader's own notice that it added the layer is not a validation finding.
    const char* id = data->pMessageIdName ? data->pMessageIdName : "";
    if (std::strcmp(id, "Loader Message") != 0) {
      ++counters->messages;
      {
        const std::lock_guard<std::mutex> lock(counters->mutex);
        counters->lastId = id;
      }
      if (counters->print) std::fprintf(stderr, "[vulkan validation] %s\n", data->pMessage);
    }
  }
  return VK_FALSE;
}

bool hasLayer(const char* name) {
  std::uint32_t n = 0;
  vkEnumerateInstanceLayerProperties(&n, nullptr);
  std::vector<VkLayerProperties> layers(n);
  vkEnumerateInstanceLayerProperties(&n, layers.data());
  return std::any_of(layers.begin(), layers.end(),
                     [&](const VkLayerProperties& l) { return std::strcmp(l.layerName, name) == 0; });
}

VkInstance createInstance(bool validation) {
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "blobvk";
  app.pEngineName = "blobvk";
  app.apiVersion = VK_API_VERSION_1_1;
  std::vector<const char*> layers, extensions;
  // Synchronisation validation on top of the layer's default (core) checks, enabled here so
  // that --validation means the same whatever VK_LAYER_ENABLES or vk_layer_settings.txt say.
  // VK_EXT_validation_features is implemented by the layer itself.
  const VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
  VkValidationFeaturesEXT features{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
  features.enabledValidationFeatureCount = 1;
  features.pEnabledValidationFeatures = enables;
  if (validation) {
    if (!hasLayer("VK_LAYER_KHRONOS_validation")) {
      throw VulkanError("validation requested but VK_LAYER_KHRONOS_validation is not installed "
                        "(install vulkan-validationlayers)");
    }
    layers.push_back("VK_LAYER_KHRONOS_validation");
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    extensions.push_back(VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME);
  }
  VkInstanceCreateInfo info{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  if (validation) info.pNext = &features;
  info.pApplicationInfo = &app;
  info.enabledLayerCount = std::uint32_t(layers.size());
  info.ppEnabledLayerNames = layers.data();
  info.enabledExtensionCount = std::uint32_t(extensions.size());
  info.ppEnabledExtensionNames = extensions.data();
  VkInstance instance = VK_NULL_HANDLE;
  const VkResult r = vkCreateInstance(&info, nullptr, &instance);
  if (r == VK_ERROR_INCOMPATIBLE_DRIVER) throw VulkanError(kNoDevice, r);
  check(r, "vkCreateInstance");
  return instance;
}

std::vector<VkPhysicalDevice> physicalDevices(VkInstance instance) {
  std::uint32_t n = 0;
  check(vkEnumeratePhysicalDevices(instance, &n, nullptr), "vkEnumeratePhysicalDevices");
  std::vector<VkPhysicalDevice> devices(n);
  check(vkEnumeratePhysicalDevices(instance, &n, devices.data()), "vkEnumeratePhysicalDevices");
  devices.resize(n);
  return devices;
}

DeviceInfo describe(VkPhysicalDevice pd) {
  VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
  VkPhysicalDeviceProperties2 props{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  props.pNext = &subgroup;
  vkGetPhysicalDeviceProperties2(pd, &props);
  DeviceInfo info;
  info.name = props.properties.deviceName;
  info.type = props.properties.deviceType;
  info.apiVersion = props.properties.apiVersion;
  info.subgroupSize = subgroup.subgroupSize;
  info.limits = props.properties.limits;
  return info;
}

int typeRank(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 3;
    default: return 4;
  }
}

std::string lower(std::string s) {
  for (auto& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// `what` names the request in errors ("--device 'x'", or a --devices entry).
std::size_t matchDevice(const std::vector<DeviceInfo>& infos, const std::string& request, const std::string& what) {
  if (std::all_of(request.begin(), request.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
    const std::size_t index = request.size() > 9 ? infos.size() : std::stoul(request);
    if (index >= infos.size()) {
      throw VulkanError(what + ": only " + std::to_string(infos.size()) + " Vulkan device(s) (see `blobvk devices`)");
    }
    return index;
  }
  for (std::size_t i = 0; i < infos.size(); ++i) {
    if (lower(infos[i].name).find(lower(request)) != std::string::npos) return i;
  }
  throw VulkanError(what + " matches no Vulkan device (see `blobvk devices`)");
}

std::size_t pickDevice(const std::vector<DeviceInfo>& infos, const std::string& request) {
  if (infos.empty()) throw VulkanError(kNoDevice);
  if (!request.empty()) {
    const bool index = std::all_of(request.begin(), request.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); });
    return matchDevice(infos, request, index ? "--device " + request : "--device '" + request + "'");
  }
  std::size_t best = 0;
  for (std::size_t i = 1; i < infos.size(); ++i) {
    if (typeRank(infos[i].type) < typeRank(infos[best].type)) best = i;
  }
  return best;
}

}  // namespace

const char* deviceTypeName(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "CPU";
    default: return "other";
  }
}

std::vector<DeviceInfo> listDevices() {
  VkInstance instance = createInstance(false);
  std::vector<DeviceInfo> infos;
  try {
    for (auto pd : physicalDevices(instance)) infos.push_back(describe(pd));
  } catch (...) {
    vkDestroyInstance(instance, nullptr);
    throw;
  }
  vkDestroyInstance(instance, nullptr);
  return infos;
}

std::vector<std::size_t> resolveDeviceList(const std::string& list, const std::vector<DeviceInfo>& infos) {
  const std::string what = "--devices '" + list + "'";
  if (infos.empty()) throw VulkanError(kNoDevice);
  std::vector<std::size_t> picked;
  if (lower(list) == "all") {
    const bool gpu = std::any_of(infos.begin(), infos.end(),
                                 [](const DeviceInfo& i) { return i.type != VK_PHYSICAL_DEVICE_TYPE_CPU; });
    for (std::size_t i = 0; i < infos.size(); ++i) {
      if (!gpu || infos[i].type != VK_PHYSICAL_DEVICE_TYPE_CPU) picked.push_back(i);
    }
    return picked;
  }
  std::size_t begin = 0;
  for (int entry = 1;; ++entry) {
    const std::size_t end = std::min(list.find(',', begin), list.size());
    std::string request = list.substr(begin, end - begin);
    request.erase(0, std::min(request.find_first_not_of(' '), request.size()));
    request.erase(request.find_last_not_of(' ') + 1);
    if (request.empty()) {
      throw VulkanError(what + ": entry " + std::to_string(entry) + " is empty (a comma-separated list of device indices or names, or all)");
    }
    picked.push_back(matchDevice(infos, request, what + ": entry '" + request + "'"));
    if (end == list.size()) break;
    begin = end + 1;
  }
  if (picked.size() > kMaxListedDevices) {
    throw VulkanError(what + ": " + std::to_string(picked.size()) + " entries, at most " + std::to_string(kMaxListedDevices));
  }
  return picked;
}

bool vulkanAvailable(std::string* why) {
  try {
    if (listDevices().empty()) throw VulkanError(kNoDevice);
    return true;
  } catch (const std::exception& e) {
    if (why) *why = e.what();
    return false;
  }
}

StandaloneContext::StandaloneContext(const StandaloneOptions& options)
    : counters_(std::make_unique<Counters>()) {
  counters_->print = options.printValidationMessages;
  host_.instance = createInstance(options.validation);
  host_.getInstanceProcAddr = vkGetInstanceProcAddr;
  host_.instanceApiVersion = VK_API_VERSION_1_1;  // the VkApplicationInfo above
  try {
    if (options.validation) {
      auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
          vkGetInstanceProcAddr(host_.instance, "vkCreateDebugUtilsMessengerEXT"));
      VkDebugUtilsMessengerCreateInfoEXT info{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
      info.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                             VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
      info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                         VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                         VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
      info.pfnUserCallback = onMessage;
      info.pUserData = counters_.get();
      check(create(host_.instance, &info, nullptr, &messenger_), "vkCreateDebugUtilsMessengerEXT");
    }
    const auto devices = physicalDevices(host_.instance);
    std::vector<DeviceInfo> infos;
    for (auto pd : devices) infos.push_back(describe(pd));
    const std::size_t index = pickDevice(infos, options.device);
    host_.physicalDevice = devices[index];
    if (VK_API_VERSION_MAJOR(infos[index].apiVersion) == 1 &&
        VK_API_VERSION_MINOR(infos[index].apiVersion) < 1) {
      throw VulkanError("device '" + infos[index].name + "' supports only Vulkan 1.0; blobvk needs 1.1");
    }

    std::uint32_t familyCount = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(host_.physicalDevice, &familyCount, nullptr);
    std::vector<VkQueueFamilyProperties> families(familyCount);
    vkGetPhysicalDeviceQueueFamilyProperties(host_.physicalDevice, &familyCount, families.data());
    // Prefer a compute-capable family with timestamps.
    std::uint32_t family = ~0u;
    for (std::uint32_t i = 0; i < familyCount; ++i) {
      if (!(families[i].queueFlags & VK_QUEUE_COMPUTE_BIT)) continue;
      if (family == ~0u || (families[i].timestampValidBits && !families[family].timestampValidBits)) family = i;
    }
    if (family == ~0u) {
      throw VulkanError("device '" + infos[index].name + "' has no compute queue (missing feature)");
    }
    const float priority = 1.0f;
    VkDeviceQueueCreateInfo queueInfo{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    queueInfo.queueFamilyIndex = family;
    queueInfo.queueCount = 1;
    queueInfo.pQueuePriorities = &priority;
    VkDeviceCreateInfo deviceInfo{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
    deviceInfo.queueCreateInfoCount = 1;
    deviceInfo.pQueueCreateInfos = &queueInfo;
    check(vkCreateDevice(host_.physicalDevice, &deviceInfo, nullptr, &host_.device), "vkCreateDevice");
    host_.queueFamilyIndex = family;
    vkGetDeviceQueue(host_.device, family, 0, &host_.queue);
    DeviceOptions deviceOptions;
    deviceOptions.retainedMemoryBytes = DeviceOptions::kAutoRetainOwnedDevice;  // the VkDevice is blobvk's alone
    if (const auto dir = resolvePipelineCacheDir(options.pipelineCache); !dir.empty()) {
      VkPhysicalDeviceProperties properties;
      vkGetPhysicalDeviceProperties(host_.physicalDevice, &properties);
      cacheKey_ = std::make_unique<PipelineCacheKey>(pipelineCacheKey(properties));
      cacheFile_ = vk::pipelineCacheFile(dir, *cacheKey_);
      std::string problem;
      cacheLoaded_ = readPipelineCacheFile(cacheFile_, *cacheKey_, problem);
      if (!problem.empty()) {
        // A directory or device in the file's place cannot be replaced: say so once, and do not
        // try (and warn again) on exit.
        std::error_code ec;
        const bool replaceable = !std::filesystem::exists(cacheFile_, ec) || std::filesystem::is_regular_file(cacheFile_, ec);
        // The same file in the same state is one warning; a file spoiled again is another.
        const auto size = std::filesystem::is_regular_file(cacheFile_, ec) ? std::filesystem::file_size(cacheFile_, ec) : 0;
        const auto time = std::filesystem::last_write_time(cacheFile_, ec).time_since_epoch().count();
        warnOncePerProcess(cacheFile_.string() + "|" + problem + "|" + std::to_string(size) + "|" + std::to_string(time), "blobvk: warning: pipeline cache " + cacheFile_.string() + " " + problem +
                                                     (replaceable ? "; ignoring it (it is rewritten on exit)"
                                                                  : "; ignoring it (and not saving one there)"));
        if (!replaceable) cacheFile_.clear();
      }
      deviceOptions.pipelineCacheData = cacheLoaded_;
      deviceOptions.spirvCacheDir = dir.string();
    }
    device_ = std::make_unique<Device>(host_, deviceOptions);
  } catch (...) {
    release();
    throw;
  }
}

StandaloneContext::~StandaloneContext() {
  savePipelineCache();
  release();
}

void StandaloneContext::savePipelineCache() noexcept {
  if (!device_ || cacheFile_.empty()) return;
  try {
    const auto data = device_->pipelineCacheData();
    if (data == cacheLoaded_) return;  // nothing new: leave the file (and its readers) alone
    writePipelineCacheFile(cacheFile_, *cacheKey_, data);
  } catch (const std::exception& e) {
    // One line per file and process: a command may hold several contexts on one cache file
    // (compare's fields and meshes, a kernel warm-up's second device), each failing alike.
    static std::mutex mutex;
    static std::set<std::string> warned;
    const std::lock_guard<std::mutex> lock(mutex);
    if (warned.insert(cacheFile_).second)
      std::fprintf(stderr, "blobvk: warning: pipeline cache not saved: %s\n", e.what());
  }
}

void StandaloneContext::release() {
  device_.reset();
  if (host_.device) vkDestroyDevice(host_.device, nullptr);
  host_.device = VK_NULL_HANDLE;
  if (messenger_) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(host_.instance, "vkDestroyDebugUtilsMessengerEXT"));
    destroy(host_.instance, messenger_, nullptr);
    messenger_ = VK_NULL_HANDLE;
  }
  if (host_.instance) vkDestroyInstance(host_.instance, nullptr);
  host_.instance = VK_NULL_HANDLE;
}

std::uint32_t StandaloneContext::validationMessages() const { return counters_->messages.load(); }

std::string StandaloneContext::lastValidationMessageId() const {
  const std::lock_guard<std::mutex> lock(counters_->mutex);
  return counters_->lastId;
}

}  // namespace blobvk::vk
