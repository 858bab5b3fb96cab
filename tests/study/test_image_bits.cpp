// converters.image_bits (issue 51): the layers that read the network's image quantize it at a
// precision of their own (NeuRRAM: 4-bit pixels, 3-bit activations). References: the slicing
// and the DAC's levels by hand, the neuron's steps by hand, the refusal's key.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "sw/common/errors.h"
#include "sw/inference/crossbar_backend.h"
#include "sw/nn/dataset.h"
#include "sw/nn/presets.h"
#include "sw/study/hardware.h"

namespace xbarsim {
namespace {

TEST(ImageBits, ForLayerByHand) {
  ConvertersSpec c;
  c.input_bits = 3;
  c.dac_bits = 3;  // one read per activation: the image's DAC reads its whole code too
  c.image_bits = 4;
  EXPECT_EQ(c.for_layer(false).input_bits, 3);
  EXPECT_EQ(c.for_layer(false).dac_bits, 3);
  EXPECT_EQ(c.for_layer(true).input_bits, 4);
  EXPECT_EQ(c.for_layer(true).dac_bits, 4);
  c.input_bits = 8;
  c.dac_bits = 1;  // bit-serial: the image streams through the same 1-bit DACs
  EXPECT_EQ(c.for_layer(true).input_bits, 4);
  EXPECT_EQ(c.for_layer(true).dac_bits, 1);
  c.image_bits = 0;  // none: every layer alike
  EXPECT_EQ(c.for_layer(true).input_bits, 8);
}

TEST(ImageBits, OnlyTheLayersReadingTheInputReadTheImage) {
  for (const char* name : {"lenet", "resnet20"}) {
    const Model m = make_preset(name, 3);
    const std::vector<bool> r = linear_reads_image(m);
    ASSERT_EQ(r.size(), m.linear.size());
    EXPECT_TRUE(r[0]) << name;
    for (size_t l = 1; l < r.size(); ++l) EXPECT_FALSE(r[l]) << name << " layer " << l;
  }
}

TEST(ImageBits, TheFirstLayerQuantizesAtItsBits) {
  const Model m = make_preset("lenet", 3);
  const Dataset calib = random_dataset(m.input, 4, 5);
  for (const char* dac : {"3", "1"}) {
    AnalogConfig ac = parse_analog_config(ConfigTree::load(
        "", {"converters.input_bits=3", std::string("converters.dac_bits=") + dac, "converters.image_bits=5",
             "converters.adc_bits=none", "eval.calibration_samples=64"}));
    CrossbarBackend xb(m, ac);
    xb.program(calib, 64);
    const bool s0 = xb.statistics(0).signed_inputs, s1 = xb.statistics(1).signed_inputs;
    const InputSlicing& image = xb.layer(0).input_slicing();
    const InputSlicing& next = xb.layer(1).input_slicing();
    // 5 bits: a sign and 4 magnitude bits (signed) or 5; the others 3 bits.
    EXPECT_EQ(image.magnitude_bits, s0 ? 4 : 5) << dac;
    EXPECT_EQ(next.magnitude_bits, s1 ? 2 : 3) << dac;
    if (std::string(dac) == "3") {  // one read per input, the image's DAC 5 bits wide
      EXPECT_EQ(image.slices, 1);
      EXPECT_EQ(next.slices, 1);
    } else {  // 1-bit DACs: a read per magnitude bit and a sign read (signed), or a read per bit
      EXPECT_EQ(image.slices, 5);
      EXPECT_EQ(next.slices, 3);
    }
    // The DAC's levels: x at 0.3 of the full scale rounds to the nearest of 2^m - 1 steps.
    const double x_max = xb.statistics(0).x_max;
    float v = static_cast<float>(0.3 * x_max);
    xb.layer(0).dac_values<float>(&v, 1);
    const double steps = std::ldexp(1.0, image.magnitude_bits) - 1;
    EXPECT_NEAR(v, std::round(0.3 * steps) / steps * x_max, 1e-5 * x_max) << dac;
  }
}

TEST(ImageBits, NeuronCoresReadTheImageInTheCyclesItsStepsNeed) {
  const ConfigTree cfg = ConfigTree::load(XBARSIM_SOURCE_DIR "/configs/neurram.yaml", {"converters.image_bits=4"});
  const HardwareContext hw = make_hardware_context(cfg, parse_analog_config(cfg));
  // (3, 5): 3 integrations of 270 ns, 5 ADC steps of 300, a phase of 300: 2610 ns, the clock.
  // (4, 5): 3 magnitude bits in one phase, 7 integrations: 3690 ns, two cycles.
  EXPECT_DOUBLE_EQ(hw.read_steps.time_ns, 3 * 270 + 5 * 300 + 300);
  EXPECT_DOUBLE_EQ(hw.image_read_steps.time_ns, 7 * 270 + 5 * 300 + 300);
  EXPECT_EQ(hw.platform.image_read_cycles, 2);
  const ConfigTree none = ConfigTree::load(XBARSIM_SOURCE_DIR "/configs/neurram.yaml", {"converters.image_bits=none"});
  EXPECT_EQ(make_hardware_context(none, parse_analog_config(none)).platform.image_read_cycles, 1);
}

TEST(ImageBits, AWiderImageDacThanThePricedOneIsRefused) {
  // The default: 8-bit DACs, one read per input; a 10-bit image would need 10-bit DACs.
  const ConfigTree cfg = ConfigTree::load("", {"converters.image_bits=10"});
  try {
    make_hardware_context(cfg, parse_analog_config(cfg));
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("converters.image_bits"), std::string::npos) << e.what();
  }
  const ConfigTree ok = ConfigTree::load("", {"converters.image_bits=6"});
  EXPECT_NO_THROW(make_hardware_context(ok, parse_analog_config(ok)));
  EXPECT_THROW(parse_analog_config(ConfigTree::load("", {"converters.image_bits=0"})), InputError);
}

}  // namespace
}  // namespace xbarsim
