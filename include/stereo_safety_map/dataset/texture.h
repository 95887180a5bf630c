// Band-limited procedural textures of the synthetic datasets. Patterns are functions of surface
// coordinates in metres, so both cameras of the stereo pair see the same albedo at the same 3D
// point. Detail finer than the pixel footprint fades out (like a pixel integrating the surface),
// which keeps the left and right images consistent instead of aliased differently. ROS-free.
#pragma once

#include "stereo_safety_map/dataset/scene.h"

#include <cstdint>

namespace stereo_safety_map {
namespace dataset {

/// Smooth 2D value noise in [-1, 1] with unit lattice spacing.
double valueNoise(double u, double v, std::uint32_t seed);

/// Fractal sum of value noise whose largest wavelength is `scale` [m]; octaves shorter than
/// about 3 footprints are faded out. Roughly zero mean, clamped to [-1, 1].
double fractalNoise(double u, double v, double scale, double footprint, std::uint32_t seed);

/// Texture value t in [-1, 1] of a material at surface coordinates (u, v) [m], for a pixel
/// footprint `footprint` [m] (> 0). Albedo = colour * (1 + contrast * t).
double evaluateTexture(const Material& m, double u, double v, double footprint);

/// Surface grain of a material at surface coordinates (u, v) [m] seen with a pixel footprint
/// [m]: three octaves of value noise with equal amplitude at grain_size x 1, 2, 4, each faded
/// out below the Nyquist limit; roughly in [-1, 1] (multiply by Material::effectiveGrain()).
double evaluateGrain(const Material& m, double u, double v, double footprint);

}  // namespace dataset
}  // namespace stereo_safety_map
