#pragma once
/// Built-in network topologies with seeded random weights, for timing/power/area studies
/// without data: the same graphs as the shared ONNX models.
#include <cstdint>
#include <string>

#include "sw/nn/model.h"

namespace xbarsim {

/// "lenet" (Caffe LeNet on 1x28x28: conv5x5x1x20, maxpool2, conv5x5x20x50, maxpool2,
/// fc 800->500, ReLU, fc 500->10; no ReLU after the convolutions) or "resnet20",
/// "resnet32", "resnet56" (CIFAR ResNet on 3x32x32, 16/32/64 channels, option-A
/// shortcuts: stride-2 subsampling and zero channel padding, no shortcut convolution).
/// Weights are He-normal from `seed`, biases zero. Throws InputError for other names.
Model make_preset(const std::string& name, uint64_t seed = 1);

}  // namespace xbarsim
