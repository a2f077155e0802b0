// One dispatch of AMD FidelityFX VRS's shading-rate-image pass (compiled to SPIR-V by run.py) on a Vulkan device
// (Mesa's lavapipe): the colour input as a sampled RGBA32F image, the motion vectors as a sampled RG16F image of
// zeros, the SRI as an R8_UINT storage image, AMD's constant block as a uniform buffer. Writes the SRI's texels,
// rows top first, to OUT. Not part of CI; run.py builds and runs it (gcc vrs_dispatch.c -lvulkan).
//
//   vrs_dispatch --info
//   vrs_dispatch SPV ENTRY COLOR.f32 WIDTH HEIGHT TILE CUTOFF MOTION_FACTOR OUT.u8 BIND_COLOR,BIND_MOTION,BIND_SRI,BIND_CB WAVE FMT [EXTRA]
//
// WAVE > 0 asks for that subgroup size (VK_EXT_subgroup_size_control; full subgroups where the group's width, 8
// threads, 16 at tile 32 of the base build, is a multiple of it: lavapipe fills a subgroup along x only, so a wider subgroup holds one
// row of threads). 0 takes the driver's: lavapipe 22.3 then reduces over 4 lanes whatever gl_SubgroupSize says.
// FMT: the SRI image's format, r8 (R8_UINT, as AMD's GLSL declares it) or r32 (R32_UINT: glslang gives HLSL's
// RWTexture2D<uint> that format, and a storage image's format must match its declaration).
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <vulkan/vulkan.h>

#define CHECK(x)                                                                                                      \
    do {                                                                                                              \
        VkResult r_ = (x);                                                                                            \
        if (r_ != VK_SUCCESS) {                                                                                       \
            fprintf(stderr, "vrs_dispatch: %s failed: VkResult %d (line %d)\n", #x, r_, __LINE__);                  \
            exit(3);                                                                                                  \
        }                                                                                                             \
    } while (0)

static VkDevice dev;
static VkPhysicalDevice phys;

static void *slurp(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (!f) { fprintf(stderr, "vrs_dispatch: cannot open %s\n", path); exit(2); }
    fseek(f, 0, SEEK_END);
    *len = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    void *p = malloc(*len ? *len : 1);
    if (fread(p, 1, *len, f) != *len) { fprintf(stderr, "vrs_dispatch: short read %s\n", path); exit(2); }
    fclose(f);
    return p;
}

static uint32_t memtype(uint32_t bits, VkMemoryPropertyFlags want) {
    VkPhysicalDeviceMemoryProperties mp;
    vkGetPhysicalDeviceMemoryProperties(phys, &mp);
    for (uint32_t i = 0; i < mp.memoryTypeCount; i++)
        if ((bits & (1u << i)) && (mp.memoryTypes[i].propertyFlags & want) == want) return i;
    fprintf(stderr, "vrs_dispatch: no memory type\n");
    exit(3);
}

static VkDeviceMemory bind(VkMemoryRequirements req, VkMemoryPropertyFlags want) {
    VkMemoryAllocateInfo ai = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, NULL, req.size, memtype(req.memoryTypeBits, want)};
    VkDeviceMemory m;
    CHECK(vkAllocateMemory(dev, &ai, NULL, &m));
    return m;
}

static VkBuffer buffer(VkDeviceSize size, VkBufferUsageFlags usage, VkDeviceMemory *mem, void **map) {
    VkBufferCreateInfo bi = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    bi.size = size;
    bi.usage = usage;
    VkBuffer b;
    CHECK(vkCreateBuffer(dev, &bi, NULL, &b));
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(dev, b, &req);
    *mem = bind(req, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    CHECK(vkBindBufferMemory(dev, b, *mem, 0));
    CHECK(vkMapMemory(dev, *mem, 0, VK_WHOLE_SIZE, 0, map));
    return b;
}

static VkImage image(VkFormat fmt, uint32_t w, uint32_t h, VkImageUsageFlags usage, VkImageView *view) {
    VkImageCreateInfo ii = {VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    ii.imageType = VK_IMAGE_TYPE_2D;
    ii.format = fmt;
    ii.extent = (VkExtent3D){w, h, 1};
    ii.mipLevels = 1;
    ii.arrayLayers = 1;
    ii.samples = VK_SAMPLE_COUNT_1_BIT;
    ii.tiling = VK_IMAGE_TILING_OPTIMAL;
    ii.usage = usage;
    ii.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VkImage im;
    CHECK(vkCreateImage(dev, &ii, NULL, &im));
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(dev, im, &req);
    CHECK(vkBindImageMemory(dev, im, bind(req, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT), 0));
    VkImageViewCreateInfo vi = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vi.image = im;
    vi.viewType = VK_IMAGE_VIEW_TYPE_2D;
    vi.format = fmt;
    vi.subresourceRange = (VkImageSubresourceRange){VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    CHECK(vkCreateImageView(dev, &vi, NULL, view));
    return im;
}

static void barrier(VkCommandBuffer cb, VkImage im, VkImageLayout from, VkImageLayout to, VkAccessFlags src,
                    VkAccessFlags dst, VkPipelineStageFlags s0, VkPipelineStageFlags s1) {
    VkImageMemoryBarrier b = {VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
    b.srcAccessMask = src;
    b.dstAccessMask = dst;
    b.oldLayout = from;
    b.newLayout = to;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = im;
    b.subresourceRange = (VkImageSubresourceRange){VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdPipelineBarrier(cb, s0, s1, 0, 0, NULL, 0, NULL, 1, &b);
}

int main(int argc, char **argv) {
    int info = argc == 2 && !strcmp(argv[1], "--info");
    if (!info && argc != 13 && argc != 14) {
        fprintf(stderr, "usage: vrs_dispatch --info | SPV ENTRY COLOR.f32 WIDTH HEIGHT TILE CUTOFF MOTION_FACTOR OUT.u8 "
                        "BC,BM,BS,BU WAVE r8|r32 [EXTRA 0|1]\n");
        return 2;
    }
    VkApplicationInfo app = {VK_STRUCTURE_TYPE_APPLICATION_INFO, NULL, "vrs_dispatch", 1, NULL, 0, VK_API_VERSION_1_3};
    VkInstanceCreateInfo ici = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO, NULL, 0, &app};
    VkInstance inst;
    CHECK(vkCreateInstance(&ici, NULL, &inst));
    uint32_t n = 1;
    VkResult er = vkEnumeratePhysicalDevices(inst, &n, &phys);
    if ((er != VK_SUCCESS && er != VK_INCOMPLETE) || n == 0) { fprintf(stderr, "vrs_dispatch: no Vulkan device\n"); return 3; }

    VkPhysicalDeviceSubgroupSizeControlProperties sscp = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_SIZE_CONTROL_PROPERTIES};
    VkPhysicalDeviceSubgroupProperties sgp = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES, &sscp};
    VkPhysicalDeviceProperties2 props = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &sgp};
    vkGetPhysicalDeviceProperties2(phys, &props);
    VkPhysicalDeviceVulkan13Features f13 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
    VkPhysicalDeviceFeatures2 feats = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &f13};
    vkGetPhysicalDeviceFeatures2(phys, &feats);
    if (info) {
        printf("device %s\nsubgroupSize %u\nminSubgroupSize %u\nmaxSubgroupSize %u\nsubgroupSizeControl %u\n"
               "robustImageAccess %u\narithmetic %u\n",
               props.properties.deviceName, sgp.subgroupSize, sscp.minSubgroupSize, sscp.maxSubgroupSize,
               f13.subgroupSizeControl, f13.robustImageAccess,
               !!(sgp.supportedOperations & VK_SUBGROUP_FEATURE_ARITHMETIC_BIT));
        return 0;
    }
    const char *spv_path = argv[1], *entry = argv[2], *color_path = argv[3], *out_path = argv[9];
    uint32_t W = (uint32_t)atoi(argv[4]), H = (uint32_t)atoi(argv[5]), tile = (uint32_t)atoi(argv[6]);
    float cutoff = (float)atof(argv[7]), motion_factor = (float)atof(argv[8]);
    uint32_t bnd[4];
    if (sscanf(argv[10], "%u,%u,%u,%u", &bnd[0], &bnd[1], &bnd[2], &bnd[3]) != 4) { fprintf(stderr, "bad bindings\n"); return 2; }
    uint32_t wave = (uint32_t)atoi(argv[11]);
    int r32 = !strcmp(argv[12], "r32");
    VkFormat sri_fmt = r32 ? VK_FORMAT_R32_UINT : VK_FORMAT_R8_UINT;
    uint32_t bpt = r32 ? 4 : 1;
    if (wave && !(f13.subgroupSizeControl && f13.computeFullSubgroups && wave >= sscp.minSubgroupSize &&
                  wave <= sscp.maxSubgroupSize)) {
        fprintf(stderr, "vrs_dispatch: %s cannot run subgroups of %u (min %u, max %u)\n", props.properties.deviceName,
                wave, sscp.minSubgroupSize, sscp.maxSubgroupSize);
        return 4;
    }

    // One compute queue; features: subgroup size control, and robust image access (an out-of-bounds texel read is
    // zero, as D3D12 defines it: AMD's pass reads its motion vectors at coordinates up to 2 pixels outside).
    uint32_t qf = 0, nq = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(phys, &nq, NULL);
    VkQueueFamilyProperties qfp[16];
    nq = nq > 16 ? 16 : nq;
    vkGetPhysicalDeviceQueueFamilyProperties(phys, &nq, qfp);
    while (qf < nq && !(qfp[qf].queueFlags & VK_QUEUE_COMPUTE_BIT)) qf++;
    float prio = 1.0f;
    VkDeviceQueueCreateInfo qci = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO, NULL, 0, qf, 1, &prio};
    VkPhysicalDeviceVulkan13Features en13 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
    en13.subgroupSizeControl = f13.subgroupSizeControl;
    en13.computeFullSubgroups = f13.computeFullSubgroups;
    en13.robustImageAccess = f13.robustImageAccess;
    VkPhysicalDeviceFeatures2 enf = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &en13};
    enf.features.shaderStorageImageWriteWithoutFormat = feats.features.shaderStorageImageWriteWithoutFormat;
    VkDeviceCreateInfo dci = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, &enf, 0, 1, &qci};
    CHECK(vkCreateDevice(phys, &dci, NULL, &dev));
    VkQueue queue;
    vkGetDeviceQueue(dev, qf, 0, &queue);

    // The SRI: ceil(size / tile) texels; the tile-8 pass writes 2 × 2 tiles per group, so round up to even. The
    // pass built with the additional rates (EXTRA 1) runs a group per 32 × 32 pixels, writing 32 / tile tiles a side.
    uint32_t cols = (W + tile - 1) / tile, rows = (H + tile - 1) / tile;
    uint32_t gx = tile == 8 ? (cols + 1) / 2 : cols, gy = tile == 8 ? (rows + 1) / 2 : rows;
    uint32_t sw = tile == 8 ? 2 * gx : cols, sh = tile == 8 ? 2 * gy : rows;
    if (argc == 14 && atoi(argv[13])) {
        uint32_t nb = 32 / tile;
        gx = (cols * tile + 31) / 32, gy = (rows * tile + 31) / 32;
        sw = gx * nb, sh = gy * nb;
    }

    size_t clen;
    float *color = slurp(color_path, &clen);
    if (clen != (size_t)W * H * 16) { fprintf(stderr, "vrs_dispatch: %s is not %ux%u RGBA32F\n", color_path, W, H); return 2; }
    VkDeviceMemory m_stage, m_out, m_cb;
    void *p_stage, *p_out, *p_cb;
    VkBuffer stage = buffer(clen, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, &m_stage, &p_stage);
    memcpy(p_stage, color, clen);
    VkBuffer outb = buffer((VkDeviceSize)sw * sh * bpt, VK_BUFFER_USAGE_TRANSFER_DST_BIT, &m_out, &p_out);
    VkBuffer cbuf = buffer(256, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, &m_cb, &p_cb);
    // AMD's cbVRS (std140): float2 motionVectorScale, float varianceCutoff, float motionFactor, int2 resolution,
    // uint tileSize.
    struct { float mvs[2]; float cutoff, motion; int32_t res[2]; uint32_t tile, pad; } cbv = {
        {1.0f, 1.0f}, cutoff, motion_factor, {(int32_t)W, (int32_t)H}, tile, 0};
    memcpy(p_cb, &cbv, sizeof cbv);

    VkImageView v_col, v_mv, v_sri;
    VkImage i_col = image(VK_FORMAT_R32G32B32A32_SFLOAT, W, H, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, &v_col);
    VkImage i_mv = image(VK_FORMAT_R16G16_SFLOAT, W, H, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, &v_mv);
    VkImage i_sri = image(sri_fmt, sw, sh,
                          VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, &v_sri);

    // Pipeline.
    size_t slen;
    uint32_t *code = slurp(spv_path, &slen);
    VkShaderModuleCreateInfo smi = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO, NULL, 0, slen, code};
    VkShaderModule sm;
    CHECK(vkCreateShaderModule(dev, &smi, NULL, &sm));
    VkDescriptorSetLayoutBinding b[4] = {
        {bnd[0], VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL},
        {bnd[1], VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL},
        {bnd[2], VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL},
        {bnd[3], VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL}};
    VkDescriptorSetLayoutCreateInfo dli = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO, NULL, 0, 4, b};
    VkDescriptorSetLayout dsl;
    CHECK(vkCreateDescriptorSetLayout(dev, &dli, NULL, &dsl));
    VkPipelineLayoutCreateInfo pli = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO, NULL, 0, 1, &dsl};
    VkPipelineLayout pl;
    CHECK(vkCreatePipelineLayout(dev, &pli, NULL, &pl));
    VkPipelineShaderStageRequiredSubgroupSizeCreateInfo rss = {
        VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_REQUIRED_SUBGROUP_SIZE_CREATE_INFO, NULL, wave};
    VkComputePipelineCreateInfo cpi = {VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    // AMD's FFX_VariableShading_ThreadCount1D: 16 at tile 32 of the base build, else 8 (always 8 with EXTRA).
    uint32_t width = tile == 32 && !(argc == 14 && atoi(argv[13])) ? 16 : 8;
    int full = wave && width % wave == 0;
    cpi.stage = (VkPipelineShaderStageCreateInfo){VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                                                  wave ? &rss : NULL,
                                                  full ? VK_PIPELINE_SHADER_STAGE_CREATE_REQUIRE_FULL_SUBGROUPS_BIT : 0,
                                                  VK_SHADER_STAGE_COMPUTE_BIT, sm, entry, NULL};
    cpi.layout = pl;
    VkPipeline pipe;
    CHECK(vkCreateComputePipelines(dev, VK_NULL_HANDLE, 1, &cpi, NULL, &pipe));

    VkDescriptorPoolSize ps[3] = {{VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, 2}, {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1},
                                  {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1}};
    VkDescriptorPoolCreateInfo dpi = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO, NULL, 0, 1, 3, ps};
    VkDescriptorPool dp;
    CHECK(vkCreateDescriptorPool(dev, &dpi, NULL, &dp));
    VkDescriptorSetAllocateInfo dai = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO, NULL, dp, 1, &dsl};
    VkDescriptorSet ds;
    CHECK(vkAllocateDescriptorSets(dev, &dai, &ds));
    VkDescriptorImageInfo ii[3] = {{VK_NULL_HANDLE, v_col, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
                                   {VK_NULL_HANDLE, v_mv, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
                                   {VK_NULL_HANDLE, v_sri, VK_IMAGE_LAYOUT_GENERAL}};
    VkDescriptorBufferInfo bfi = {cbuf, 0, sizeof cbv};
    VkWriteDescriptorSet wr[4];
    for (int i = 0; i < 4; i++) {
        wr[i] = (VkWriteDescriptorSet){VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, NULL, ds, bnd[i], 0, 1, b[i].descriptorType};
        if (i < 3) wr[i].pImageInfo = &ii[i]; else wr[i].pBufferInfo = &bfi;
    }
    vkUpdateDescriptorSets(dev, 4, wr, 0, NULL);

    // Record: upload the colour, zero the motion vectors, fill the SRI with 255 (a texel the pass never writes
    // shows), dispatch, read the SRI back.
    VkCommandPoolCreateInfo cpci = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO, NULL, 0, qf};
    VkCommandPool cp;
    CHECK(vkCreateCommandPool(dev, &cpci, NULL, &cp));
    VkCommandBufferAllocateInfo cai = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO, NULL, cp, VK_COMMAND_BUFFER_LEVEL_PRIMARY, 1};
    VkCommandBuffer cb;
    CHECK(vkAllocateCommandBuffers(dev, &cai, &cb));
    VkCommandBufferBeginInfo bi = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    CHECK(vkBeginCommandBuffer(cb, &bi));
    const VkPipelineStageFlags T = VK_PIPELINE_STAGE_TRANSFER_BIT, C = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT;
    VkImageSubresourceRange all = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    barrier(cb, i_col, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
            VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, T);
    barrier(cb, i_mv, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
            VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, T);
    barrier(cb, i_sri, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
            VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, T);
    VkBufferImageCopy reg = {0, 0, 0, {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1}, {0, 0, 0}, {W, H, 1}};
    vkCmdCopyBufferToImage(cb, stage, i_col, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &reg);
    VkClearColorValue zero = {{0}}, fill;
    memset(&fill, 0, sizeof fill);
    fill.uint32[0] = 255;
    vkCmdClearColorImage(cb, i_mv, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &zero, 1, &all);
    vkCmdClearColorImage(cb, i_sri, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &fill, 1, &all);
    barrier(cb, i_col, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
            VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT, T, C);
    barrier(cb, i_mv, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
            VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT, T, C);
    barrier(cb, i_sri, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL, VK_ACCESS_TRANSFER_WRITE_BIT,
            VK_ACCESS_SHADER_WRITE_BIT, T, C);
    vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pipe);
    vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pl, 0, 1, &ds, 0, NULL);
    vkCmdDispatch(cb, gx, gy, 1);
    barrier(cb, i_sri, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_ACCESS_SHADER_WRITE_BIT,
            VK_ACCESS_TRANSFER_READ_BIT, C, T);
    VkBufferImageCopy back = {0, 0, 0, {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1}, {0, 0, 0}, {sw, sh, 1}};
    vkCmdCopyImageToBuffer(cb, i_sri, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, outb, 1, &back);
    CHECK(vkEndCommandBuffer(cb));
    VkSubmitInfo si = {VK_STRUCTURE_TYPE_SUBMIT_INFO, NULL, 0, NULL, NULL, 1, &cb};
    CHECK(vkQueueSubmit(queue, 1, &si, VK_NULL_HANDLE));
    CHECK(vkQueueWaitIdle(queue));

    FILE *o = fopen(out_path, "wb");
    if (!o) { fprintf(stderr, "vrs_dispatch: cannot write %s\n", out_path); return 2; }
    for (uint32_t y = 0; y < rows; y++)
        for (uint32_t x = 0; x < cols; x++) {
            size_t i = (size_t)y * sw + x;
            uint32_t v = r32 ? ((uint32_t *)p_out)[i] : ((uint8_t *)p_out)[i];
            fputc(v > 255 ? 255 : (int)v, o);
        }
    fclose(o);
    fprintf(stderr, "vrs_dispatch: %s, subgroup size %u (%s), %ux%u groups, SRI %ux%u\n", props.properties.deviceName,
            wave ? wave : sgp.subgroupSize, wave ? "required" : "driver's", gx, gy, cols, rows);
    vkDestroyDevice(dev, NULL);
    vkDestroyInstance(inst, NULL);
    return 0;
}
