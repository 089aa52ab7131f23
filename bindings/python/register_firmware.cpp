// Bindings of the portable firmware cores (firmware/core, C99): psmat._core.firmware.
//
// The digital twin (docs/spec.md §5) runs the very code that runs on the microcontrollers: each class
// here is a host HAL around one device core. The "hardware" is an array the caller hands to
// tick(): the ADC counts of every row-column pair for the PSM (read through the mux
// addresses the core selects), the five sensors' Euler angles for the IMU DAQ, the ten
// sensors' counts for the material DAQ. Everything the core writes to its serial link is
// returned as bytes.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>

extern "C" {
#include "daq_core.h"
#include "imu_core.h"
#include "psm_core.h"
}

namespace py = pybind11;

namespace {

// Bytes the core wrote since the last call.
struct Link {
  std::string out;
  static void write(void* ctx, const uint8_t* data, size_t n) {
    static_cast<Link*>(ctx)->out.append(reinterpret_cast<const char*>(data), n);
  }
  py::bytes take() {
    py::bytes b(out);
    out.clear();
    return b;
  }
};

std::string as_string(const py::bytes& b) { return std::string(b); }

// ---------------------------------------------------------------------------------- PSM
class PsmFirmware {
 public:
  PsmFirmware(int rows, int cols, int protocol, const std::string& serial) : core_(new psm_core) {
    if (rows < 1 || cols < 1 || rows > PSM_MAX_ROWS || cols > PSM_MAX_COLS)
      throw std::invalid_argument("PsmFirmware: rows and cols must be in 1.." + std::to_string(PSM_MAX_ROWS));
    if (protocol != 1 && protocol != 2) throw std::invalid_argument("PsmFirmware: protocol must be 1 or 2");
    psm_hal hal{};
    hal.ctx = this;
    hal.set_row = [](void* c, uint8_t a) { static_cast<PsmFirmware*>(c)->row_addr_ = a; };
    hal.set_col = [](void* c, uint8_t a) { static_cast<PsmFirmware*>(c)->col_addr_ = a; };
    hal.read_adc = [](void* c) { return static_cast<PsmFirmware*>(c)->read_adc(); };
    hal.write = [](void* c, const uint8_t* d, size_t n) { Link::write(&static_cast<PsmFirmware*>(c)->link_, d, n); };
    hal.micros = [](void* c) { return static_cast<PsmFirmware*>(c)->now_us_; };
    hal.set_rate = [](void* c, uint32_t hz) { static_cast<PsmFirmware*>(c)->timer_hz_ = hz; };
    psm_init(core_.get(), &hal, static_cast<uint8_t>(rows), static_cast<uint8_t>(cols),
             static_cast<uint8_t>(protocol), serial.c_str());
    timer_hz_ = core_->dev.rate_hz;
  }

  // One timer interrupt: the core scans `counts` (R, C) through the mux addresses it selects.
  py::bytes tick(py::array_t<uint16_t, py::array::c_style | py::array::forcecast> counts, uint32_t t_us) {
    if (counts.ndim() != 2 || counts.shape(0) != core_->rows || counts.shape(1) != core_->cols)
      throw std::invalid_argument("tick: counts must be (" + std::to_string(core_->rows) + ", " +
                                  std::to_string(core_->cols) + ")");
    adc_ = counts.data();
    now_us_ = t_us;
    psm_on_tick(core_.get());
    adc_ = nullptr;
    return link_.take();
  }

  // Host bytes in (any chunking); the replies out.
  py::bytes receive(const py::bytes& data, uint32_t t_us) {
    const std::string s = as_string(data);
    now_us_ = t_us;
    psm_on_rx(core_.get(), reinterpret_cast<const uint8_t*>(s.data()), s.size());
    return link_.take();
  }

  int rows() const { return core_->rows; }
  int cols() const { return core_->cols; }
  bool streaming() const { return core_->dev.streaming != 0; }
  int protocol() const { return core_->dev.protocol; }
  uint32_t seq() const { return core_->dev.seq; }
  uint32_t rate_hz() const { return timer_hz_; }
  py::object hold() const {
    if (core_->hold == PM_CAL_RESUME) return py::none();
    return py::make_tuple(core_->hold >> 8, core_->hold & 0xFF);
  }

 private:
  uint16_t read_adc() const {
    // the row mux address is R-1-i (Code 2.5): the board's wiring, undone here
    const int i = core_->rows - 1 - row_addr_, p = col_addr_;
    if (!adc_ || i < 0 || i >= core_->rows || p >= core_->cols) return 0;
    return adc_[i * core_->cols + p];
  }

  std::unique_ptr<psm_core> core_;  // ~25 kB of buffers: on the heap
  Link link_;
  const uint16_t* adc_ = nullptr;
  uint8_t row_addr_ = 0, col_addr_ = 0;
  uint32_t now_us_ = 0, timer_hz_ = 0;
};

// ---------------------------------------------------------------------------------- IMU
class ImuFirmware {
 public:
  ImuFirmware(int protocol, const std::string& serial) : core_(new imu_core) {
    if (protocol != 1 && protocol != 2) throw std::invalid_argument("ImuFirmware: protocol must be 1 or 2");
    imu_hal hal{};
    hal.ctx = this;
    hal.read_euler = [](void* c, uint8_t s, float hrp[3]) {
      const float* a = static_cast<ImuFirmware*>(c)->angles_;
      for (int k = 0; k < 3; ++k) hrp[k] = a ? a[3 * s + k] : 0.0f;
    };
    hal.write = [](void* c, const uint8_t* d, size_t n) { Link::write(&static_cast<ImuFirmware*>(c)->link_, d, n); };
    hal.micros = [](void* c) { return static_cast<ImuFirmware*>(c)->now_us_; };
    hal.set_rate = [](void* c, uint32_t hz) { static_cast<ImuFirmware*>(c)->timer_hz_ = hz; };
    imu_init(core_.get(), &hal, static_cast<uint8_t>(protocol), serial.c_str());
    timer_hz_ = IMU_DEFAULT_RATE_HZ;
  }

  // One 10 Hz tick: the core reads `angles` (5, 3) degrees (heading, roll, pitch per sensor).
  py::bytes tick(py::array_t<float, py::array::c_style | py::array::forcecast> angles, uint32_t t_us) {
    if (angles.ndim() != 2 || angles.shape(0) != 5 || angles.shape(1) != 3)
      throw std::invalid_argument("tick: angles must be (5, 3) degrees");
    angles_ = angles.data();
    now_us_ = t_us;
    imu_on_tick(core_.get());
    angles_ = nullptr;
    return link_.take();
  }
  py::bytes receive(const py::bytes& data, uint32_t t_us) {
    const std::string s = as_string(data);
    now_us_ = t_us;
    imu_on_rx(core_.get(), reinterpret_cast<const uint8_t*>(s.data()), s.size());
    return link_.take();
  }
  uint32_t rate_hz() const { return timer_hz_; }

 private:
  std::unique_ptr<imu_core> core_;
  Link link_;
  const float* angles_ = nullptr;
  uint32_t now_us_ = 0, timer_hz_ = 0;
};

// ---------------------------------------------------------------------------------- DAQ
class DaqFirmware {
 public:
  DaqFirmware() : core_(new daq_core) {
    daq_hal hal{};
    hal.ctx = this;
    hal.select = [](void* c, uint8_t s) { static_cast<DaqFirmware*>(c)->sensor_ = s; };
    hal.read_adc = [](void* c) {
      auto* self = static_cast<DaqFirmware*>(c);
      return self->adc_ && self->sensor_ < 10 ? self->adc_[self->sensor_] : uint16_t{0};
    };
    hal.write = [](void* c, const uint8_t* d, size_t n) { Link::write(&static_cast<DaqFirmware*>(c)->link_, d, n); };
    daq_init(core_.get(), &hal);
  }
  // One 500 ms tick: the core reads `counts` (10,) 10-bit ADC values through its mux.
  py::bytes tick(py::array_t<uint16_t, py::array::c_style | py::array::forcecast> counts) {
    if (counts.ndim() != 1 || counts.shape(0) != 10) throw std::invalid_argument("tick: counts must be (10,)");
    adc_ = counts.data();
    daq_on_tick(core_.get());
    adc_ = nullptr;
    return link_.take();
  }
  py::bytes receive(const py::bytes& data) {
    const std::string s = as_string(data);
    daq_on_rx(core_.get(), reinterpret_cast<const uint8_t*>(s.data()), s.size());
    return link_.take();
  }
  bool running() const { return core_->running != 0; }

 private:
  std::unique_ptr<daq_core> core_;
  Link link_;
  const uint16_t* adc_ = nullptr;
  uint8_t sensor_ = 0;
};

}  // namespace

void register_firmware(py::module_& m) {
  py::class_<PsmFirmware>(m, "PsmFirmware", "The PSM firmware core (firmware/core/psm_core.c) on a host HAL.")
      .def(py::init<int, int, int, const std::string&>(), py::arg("rows"), py::arg("cols"), py::arg("protocol") = 2,
           py::arg("serial") = "TWIN0001")
      .def("tick", &PsmFirmware::tick, py::arg("counts"), py::arg("t_us"),
           "Timer IRQ: scan counts (R, C) uint16 through the muxes; returns the bytes sent.")
      .def("receive", &PsmFirmware::receive, py::arg("data"), py::arg("t_us") = 0,
           "Host bytes in; returns the replies sent.")
      .def_property_readonly("rows", &PsmFirmware::rows)
      .def_property_readonly("cols", &PsmFirmware::cols)
      .def_property_readonly("streaming", &PsmFirmware::streaming)
      .def_property_readonly("protocol", &PsmFirmware::protocol)
      .def_property_readonly("seq", &PsmFirmware::seq)
      .def_property_readonly("rate_hz", &PsmFirmware::rate_hz, "Timer rate the core asked for (Hz).")
      .def_property_readonly("hold", &PsmFirmware::hold, "(row, col) held by CAL_HOLD, or None.");
  py::class_<ImuFirmware>(m, "ImuFirmware", "The spine IMU DAQ firmware core (firmware/core/imu_core.c).")
      .def(py::init<int, const std::string&>(), py::arg("protocol") = 2, py::arg("serial") = "TWINIMU1")
      .def("tick", &ImuFirmware::tick, py::arg("angles"), py::arg("t_us"))
      .def("receive", &ImuFirmware::receive, py::arg("data"), py::arg("t_us") = 0)
      .def_property_readonly("rate_hz", &ImuFirmware::rate_hz);
  py::class_<DaqFirmware>(m, "DaqFirmware", "The material DAQ firmware core (firmware/core/daq_core.c).")
      .def(py::init<>())
      .def("tick", &DaqFirmware::tick, py::arg("counts"))
      .def("receive", &DaqFirmware::receive, py::arg("data"))
      .def_property_readonly("running", &DaqFirmware::running);
}
