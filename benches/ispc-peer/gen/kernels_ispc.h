// Stand-in for the header the ISPC compiler generates from examples/cpu/deferred/kernels.ispc
// (`ispc kernels.ispc -h kernels_ispc.h`). Only the two structs the serial C++ path (dynamic_c.cpp,
// common.cpp) needs are declared, field for field as in kernels.ispc:
//   unsigned int16 -> uint16_t, unsigned int8 -> uint8_t, int32 -> int32_t, float -> float.
// The exported ISPC functions (RenderStatic, ...) are not declared: main.cpp, which calls them, is not built.
// Written for the gbuf peer measurement (issue 14); not part of ISPC.
#ifndef KERNELS_ISPC_H_STANDIN
#define KERNELS_ISPC_H_STANDIN
#include <stdint.h>

namespace ispc {

#ifndef __ISPC_STRUCT_InputDataArrays__
#define __ISPC_STRUCT_InputDataArrays__
struct InputDataArrays {
    float *zBuffer;
    uint16_t *normalEncoded_x; // half float
    uint16_t *normalEncoded_y; // half float
    uint16_t *specularAmount;  // half float
    uint16_t *specularPower;   // half float
    uint8_t *albedo_x;         // unorm8
    uint8_t *albedo_y;         // unorm8
    uint8_t *albedo_z;         // unorm8
    float *lightPositionView_x;
    float *lightPositionView_y;
    float *lightPositionView_z;
    float *lightAttenuationBegin;
    float *lightColor_x;
    float *lightColor_y;
    float *lightColor_z;
    float *lightAttenuationEnd;
};
#endif

#ifndef __ISPC_STRUCT_InputHeader__
#define __ISPC_STRUCT_InputHeader__
struct InputHeader {
    float cameraProj[4][4];
    float cameraNear;
    float cameraFar;
    int32_t framebufferWidth;
    int32_t framebufferHeight;
    int32_t numLights;
    int32_t inputDataChunkSize;
    int32_t inputDataArrayOffsets[16]; // idaNum in deferred.h
};
#endif

} // namespace ispc

static_assert(sizeof(ispc::InputHeader) == 152, "the .bin header is 152 bytes");
#endif
