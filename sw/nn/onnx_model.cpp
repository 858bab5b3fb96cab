#include <onnx/onnx_pb.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "sw/common/errors.h"
#include "sw/common/input_file.h"
#include "sw/common/parse.h"
#include "sw/nn/model.h"

namespace xbarsim {

namespace {

struct Init {
  std::vector<int64_t> dims;
  std::vector<float> f;    ///< FLOAT data
  std::vector<int64_t> i;  ///< INT64 or INT32 data
  bool is_int32 = false;
};

constexpr int64_t kMaxTensorElements = int64_t{1} << 31;  ///< far above any CNN layer here
constexpr int64_t kMaxDim = 1 << 20;                      ///< one spatial/channel dimension

/// Copies `count` elements of a repeated field or of raw_data (little-endian) into `out`,
/// checking that exactly `count` are present.
template <typename T, typename Field>
void copy_elements(const std::string& raw, const Field& field, size_t count, std::vector<T>& out,
                   const std::string& what) {
  if (!raw.empty()) {
    if (raw.size() != count * sizeof(T))
      throw InputError(what + " holds " + std::to_string(raw.size()) + " bytes of raw data, but its dims need " +
                       std::to_string(count * sizeof(T)));
    out.resize(count);
    std::memcpy(out.data(), raw.data(), raw.size());
    return;
  }
  if (static_cast<size_t>(field.size()) != count)
    throw InputError(what + " holds " + std::to_string(field.size()) + " values, but its dims need " +
                     std::to_string(count));
  out.assign(field.begin(), field.end());
}

/// One checked reader for every tensor: dims >= 0 whose product fits, the element count
/// of raw or typed data equal to that product, and a supported data type.
Init read_tensor(const onnx::TensorProto& t, const std::string& where) {
  const std::string what = where + ": tensor '" + t.name() + "'";
  if (t.data_location() == onnx::TensorProto::EXTERNAL) throw InputError(what + " uses external data (not supported)");
  Init out;
  int64_t count = 1;
  for (auto d : t.dims()) {
    if (d < 0 || d > kMaxTensorElements || (d > 0 && count > kMaxTensorElements / d))
      throw InputError(what + " has invalid or too large dims");
    out.dims.push_back(d);
    count *= d;
  }
  const std::string& raw = t.raw_data();
  switch (t.data_type()) {
    case onnx::TensorProto::FLOAT:
      copy_elements<float>(raw, t.float_data(), static_cast<size_t>(count), out.f, what);
      break;
    case onnx::TensorProto::INT64:
      copy_elements<int64_t>(raw, t.int64_data(), static_cast<size_t>(count), out.i, what);
      break;
    case onnx::TensorProto::INT32: {
      std::vector<int32_t> v;
      copy_elements<int32_t>(raw, t.int32_data(), static_cast<size_t>(count), v, what);
      out.i.assign(v.begin(), v.end());
      out.is_int32 = true;
      break;
    }
    default:
      throw InputError(what + " has unsupported data type " + std::to_string(t.data_type()) +
                       " (float32 weights, int32/int64 shapes and indices)");
  }
  return out;
}

Op make_op(OpKind kind, const std::string& name, std::vector<int> in) {
  Op op;
  op.kind = kind;
  op.name = name;
  op.in = std::move(in);
  return op;
}

class Loader {
 public:
  Loader(const onnx::ModelProto& m, const std::string& path, Model& model) : m_(m), path_(path), model_(model) {}

  void run(Shape input_override) {
    const auto& g = m_.graph();
    for (const auto& t : g.initializer()) inits_[t.name()] = read_tensor(t, path_);
    // Graph input: the first input that is not an initializer.
    std::string input_name;
    for (const auto& in : g.input())
      if (!inits_.count(in.name())) {
        input_name = in.name();
        Shape s;
        const auto& dims = in.type().tensor_type().shape().dim();
        if (dims.size() == 4) {
          auto dim = [&](int q) {
            const int64_t v = dims[q].dim_value();
            return v >= 1 && v <= kMaxDim ? static_cast<int>(v) : 0;
          };
          s.c = dim(1);
          s.h = dim(2);
          s.w = dim(3);
        }
        if (input_override.c > 0) s = input_override;
        if (s.c <= 0 || s.h <= 0 || s.w <= 0)
          throw InputError(path_ + ": input '" + in.name() + "' must be N x C x H x W with known C, H, W");
        model_.input = s;
        break;
      }
    if (input_name.empty()) throw InputError(path_ + ": the graph has no input");
    define(input_name, model_.input);
    // Every node whose operator is not supported, named at once (not only the first).
    std::vector<std::string> unsupported;
    for (const auto& node : g.node()) {
      if (node.op_type() != "Constant" && !ops().count(node.op_type()))
        unsupported.push_back("'" + node.name() + "' (" + node.op_type() + ")");
    }
    if (!unsupported.empty()) {
      std::string list, names;
      for (const std::string& u : unsupported) list += (list.empty() ? "" : ", ") + u;
      for (const auto& [name, adder] : ops()) names += name + ", ";
      throw InputError(path_ + ": " + std::to_string(unsupported.size()) + " node" +
                       (unsupported.size() == 1 ? " has an unsupported operator: " : "s have unsupported operators: ") +
                       list + " (supported: " + names + "Constant)");
    }
    refuse_redefinitions();
    for (const auto& node : g.node()) add_node(node);
    if (g.output_size() != 1) throw InputError(path_ + ": expected exactly one graph output");
    if (model_.linear.empty()) throw InputError(path_ + ": the graph has no Conv, Gemm or MatMul layer");
    model_.output = value(g.output(0).name(), "graph output");
    fold_biases();
  }

 private:
  std::string where(const onnx::NodeProto& n) const {
    return path_ + ": node '" + n.name() + "' (" + n.op_type() + ")";
  }
  /// Every value is defined once (ONNX graphs are in SSA form): a node output that names the
  /// graph input, an initializer or another node's output is refused.
  void refuse_redefinitions() const {
    const auto& g = m_.graph();
    std::map<std::string, std::string> defined;  // value name -> what defines it
    for (const auto& t : g.initializer()) defined.emplace(t.name(), "an initializer");
    for (const auto& in : g.input()) defined.emplace(in.name(), "a graph input");
    for (const auto& node : g.node())
      for (const std::string& out : node.output()) {
        if (out.empty()) continue;  // an optional output left out
        const auto [it, fresh] = defined.emplace(out, "the output of node '" + node.name() + "'");
        if (!fresh)
          throw InputError(where(node) + ": output '" + out + "' redefines the value '" + out + "', already " +
                           it->second + " (every value must be defined once)");
      }
  }
  /// Folds into its linear layer every bias Add (an Affine op of add_arith) whose input is a
  /// linear layer's output that nothing else reads: counted over the value ids the ops read,
  /// so that a reader through any alias (Identity, Dropout, Cast, a view) counts. Then
  /// renumbers the values so that every one is some op's output (or the input).
  void fold_biases() {
    std::vector<char> removed(model_.ops.size(), 0);
    for (size_t k = 0; k < model_.ops.size(); ++k) {
      const Op& add = model_.ops[k];
      if (add.kind != OpKind::Affine || !bias_adds_.count(add.out)) continue;
      const int in = add.in[0];
      int readers = model_.output == in ? 1 : 0;
      const Op* producer = nullptr;
      for (size_t q = 0; q < model_.ops.size(); ++q) {
        if (removed[q]) continue;
        const Op& op = model_.ops[q];
        readers += static_cast<int>(std::count(op.in.begin(), op.in.end(), in));
        if (op.out == in) producer = &op;
      }
      if (readers != 1 || !producer || producer->kind != OpKind::Linear) continue;
      LinearLayer& L = model_.linear[static_cast<size_t>(producer->linear)];
      L.bias += add.shift;
      removed[k] = 1;
      const int gone = add.out;
      for (Op& op : model_.ops)
        for (int& id : op.in)
          if (id == gone) id = in;
      if (model_.output == gone) model_.output = in;
    }
    std::vector<Op> ops;
    for (size_t k = 0; k < model_.ops.size(); ++k)
      if (!removed[k]) ops.push_back(std::move(model_.ops[k]));
    model_.ops = std::move(ops);
    // Renumber: the input, then the ops' outputs in order (ids grow along the topological order).
    std::vector<int> id(model_.values.size(), -1);
    std::vector<Shape> values{model_.values[0]};
    id[0] = 0;
    for (Op& op : model_.ops) {
      id[static_cast<size_t>(op.out)] = static_cast<int>(values.size());
      values.push_back(model_.values[static_cast<size_t>(op.out)]);
    }
    for (Op& op : model_.ops) {
      for (int& v : op.in) v = id[static_cast<size_t>(v)];
      op.out = id[static_cast<size_t>(op.out)];
    }
    model_.output = id[static_cast<size_t>(model_.output)];
    model_.values = std::move(values);
  }
  int define(const std::string& name, Shape s) {
    if (s.c < 1 || s.h < 1 || s.w < 1 || s.c > kMaxDim || s.h > kMaxDim || s.w > kMaxDim ||
        static_cast<int64_t>(s.c) * s.h * s.w > (int64_t{1} << 28))
      throw InputError(path_ + ": value '" + name + "' would have shape " + std::to_string(s.c) + "x" +
                       std::to_string(s.h) + "x" + std::to_string(s.w) + " (empty or too large)");
    ids_[name] = static_cast<int>(model_.values.size());
    model_.values.push_back(s);
    return ids_[name];
  }
  /// A value no ONNX name refers to (an intermediate result of node `n`), of shape `s`.
  int define_unnamed(const onnx::NodeProto& n, Shape s) {
    if (s.size() < 1) reject(n, "empty intermediate result");
    model_.values.push_back(s);
    return static_cast<int>(model_.values.size()) - 1;
  }
  /// The id of computed value `name`, of rank 2 (N x K) or 4 (N x C x H x W).
  int value(const std::string& name, const std::string& ctx) const {
    const int id = view(name, ctx);
    const size_t rank = dims_of(name).size();
    if (rank != 2 && rank != 4)
      throw InputError(ctx + ": input '" + name + "' has rank " + std::to_string(rank) +
                       " (only Reshape, Flatten, Transpose, Squeeze, Unsqueeze and Shape read values of rank other "
                       "than 2 and 4)");
    return id;
  }
  /// The id of computed value `name`, of any rank (its data are the id's, in C, H, W order).
  int view(const std::string& name, const std::string& ctx) const {
    auto it = ids_.find(name);
    if (it == ids_.end()) {
      if (inits_.count(name))
        throw InputError(ctx + ": input '" + name + "' is a constant where this operator needs a computed value");
      throw InputError(ctx + ": input '" + name + "' is not computed by an earlier node");
    }
    return it->second;
  }
  /// The ONNX dims of computed value `name`, batch first (N = 1).
  std::vector<int64_t> dims_of(const std::string& name) const {
    const auto d = dims_.find(name);
    if (d != dims_.end()) return d->second;
    const Shape s = model_.values[static_cast<size_t>(ids_.at(name))];
    return {1, s.c, s.h, s.w};
  }
  static std::string dims_text(const std::vector<int64_t>& d) {
    std::string t;
    for (int64_t x : d) t += (t.empty() ? "" : "x") + std::to_string(x);
    return t;
  }
  /// The id of computed value `name`, of rank 4 (N x C x H x W), for node `n`.
  int map_value(const onnx::NodeProto& n, const std::string& name) const {
    const int id = value(name, where(n));
    if (dims_of(name).size() != 4)
      reject(n, "input '" + name + "' of shape " + dims_text(dims_of(name)) + " (this operator reads N x C x H x W)");
    return id;
  }
  /// `axis` of a value of dims `d` in [0, rank): a negative one counts from the end.
  int64_t normalized_axis(const onnx::NodeProto& n, int64_t axis, const std::vector<int64_t>& d) const {
    const int64_t r = static_cast<int64_t>(d.size());
    if (axis < -r || axis >= r) reject(n, "axis " + std::to_string(axis) + " of a value of rank " + std::to_string(r));
    return axis < 0 ? axis + r : axis;
  }
  /// The C x H x W that holds a value of ONNX dims `d` (batch first): rank 4 is C x H x W,
  /// rank 2 (N x K) is K x 1 x 1; any other rank is a view held as `view`.
  static Shape shape_for(const std::vector<int64_t>& d, Shape view) {
    if (d.size() == 4) return Shape{static_cast<int>(d[1]), static_cast<int>(d[2]), static_cast<int>(d[3])};
    if (d.size() == 2) return Shape{static_cast<int>(d[1]), 1, 1};
    return view;
  }
  /// Throws unless every output of node `n` is held as its ONNX dims say (shape_for): the
  /// data of every value are its dims' row-major order, so a mismatch would compute numbers
  /// ONNX does not define.
  void check_output_shapes(const onnx::NodeProto& n) const {
    for (const std::string& out : n.output()) {
      const auto it = ids_.find(out);
      if (out.empty() || it == ids_.end()) continue;
      const Shape held = model_.values[static_cast<size_t>(it->second)];
      const std::vector<int64_t> d = dims_of(out);
      int64_t count = 1;
      for (int64_t x : d) count *= x;
      if (!(shape_for(d, held) == held) || count != held.size())
        reject(n, "result '" + out + "' of shape " + dims_text(d) + " (held as " + std::to_string(held.c) + "x" +
                      std::to_string(held.h) + "x" + std::to_string(held.w) + ")");
    }
  }
  const Init& init(const std::string& name, const std::string& ctx) const {
    auto it = inits_.find(name);
    if (it == inits_.end()) throw InputError(ctx + ": '" + name + "' must be a constant initializer");
    return it->second;
  }
  /// The float32 initializer `name` with exactly `count` finite values (count < 0: any).
  const std::vector<float>& floats(const std::string& name, const std::string& ctx, int64_t count = -1) const {
    const Init& t = init(name, ctx);
    if (t.f.empty() && (!t.i.empty() || count != 0))
      throw InputError(ctx + ": '" + name + "' must hold float32 values" +
                       (t.i.empty() ? std::string() : std::string(" (it holds integers)")));
    if (count >= 0 && static_cast<int64_t>(t.f.size()) != count)
      throw InputError(ctx + ": '" + name + "' holds " + std::to_string(t.f.size()) + " values, expected " +
                       std::to_string(count));
    for (size_t k = 0; k < t.f.size(); ++k)
      if (!std::isfinite(t.f[k]))
        throw InputError(ctx + ": '" + name + "' holds a non-finite value (" + std::to_string(t.f[k]) +
                         ") at element " + std::to_string(k));
    return t.f;
  }
  /// The integer (int32 or int64) initializer `name`.
  const std::vector<int64_t>& integers(const std::string& name, const std::string& ctx) const {
    const Init& t = init(name, ctx);
    if (!t.f.empty()) throw InputError(ctx + ": '" + name + "' must hold integers (it holds floats)");
    return t.i;
  }
  /// Throws unless node `n` has at least `k` inputs and one output.
  void require_io(const onnx::NodeProto& n, int k) const {
    if (n.input_size() < k)
      throw InputError(where(n) + ": needs " + std::to_string(k) + " input(s), has " + std::to_string(n.input_size()));
    for (int q = 0; q < k; ++q)
      if (n.input(q).empty()) throw InputError(where(n) + ": input " + std::to_string(q + 1) + " is empty");
    if (n.output_size() < 1 || n.output(0).empty()) throw InputError(where(n) + ": has no output");
  }
  /// An optional input given by name (absent or empty = not given).
  static bool has_input(const onnx::NodeProto& n, int q) { return n.input_size() > q && !n.input(q).empty(); }
  /// Integer attribute list with each value in [lo, hi] and the expected length.
  std::vector<int> checked_ints(const onnx::NodeProto& n, const char* name, std::vector<int64_t> dflt, size_t len,
                                int64_t lo, int64_t hi) const {
    const auto v = ints(n, name, std::move(dflt));
    if (v.size() != len)
      throw InputError(where(n) + ": attribute '" + name + "' needs " + std::to_string(len) + " values, has " +
                       std::to_string(v.size()));
    std::vector<int> out;
    for (auto x : v) {
      if (x < lo || x > hi)
        throw InputError(where(n) + ": attribute '" + name + "' value " + std::to_string(x) + " is outside [" +
                         std::to_string(lo) + ", " + std::to_string(hi) + "]");
      out.push_back(static_cast<int>(x));
    }
    return out;
  }
  /// Output extent of a window sweep; InputError when it is empty.
  int window_out(const onnx::NodeProto& n, int in, int pad_lo, int pad_hi, int k, int stride) const {
    const long long span = static_cast<long long>(in) + pad_lo + pad_hi - k;
    if (span < 0) reject(n, "window (" + std::to_string(k) + ") larger than the padded input");
    return static_cast<int>(span / stride + 1);
  }
  static const onnx::AttributeProto* attr(const onnx::NodeProto& n, const char* name) {
    for (const auto& a : n.attribute())
      if (a.name() == name) return &a;
    return nullptr;
  }
  static std::vector<int64_t> ints(const onnx::NodeProto& n, const char* name, std::vector<int64_t> dflt) {
    const auto* a = attr(n, name);
    if (!a) return dflt;
    return std::vector<int64_t>(a->ints().begin(), a->ints().end());
  }
  static int64_t int_attr(const onnx::NodeProto& n, const char* name, int64_t dflt) {
    const auto* a = attr(n, name);
    return a ? a->i() : dflt;
  }
  static float float_attr(const onnx::NodeProto& n, const char* name, float dflt) {
    const auto* a = attr(n, name);
    return a ? a->f() : dflt;
  }
  void reject(const onnx::NodeProto& n, const std::string& what) const {
    throw InputError(where(n) + ": unsupported " + what);
  }
  void check_known_attrs(const onnx::NodeProto& n, std::initializer_list<const char*> known) const {
    for (const auto& a : n.attribute()) {
      bool ok = false;
      for (const char* k : known) ok = ok || a.name() == k;
      if (!ok) reject(n, "attribute '" + a.name() + "'");
    }
  }

  void add_linear(const onnx::NodeProto& n, LinearLayer L, int in_id, const std::vector<float>& w_oihw,
                  const std::vector<float>* bias) {
    L.name = n.name();
    L.in = model_.values[in_id];
    if (static_cast<int64_t>(L.rows()) * L.c_out > kMaxTensorElements / 4) reject(n, "layer size");
    if (w_oihw.size() != static_cast<size_t>(L.rows()) * L.c_out) reject(n, "weight size");
    const int K = L.rows();
    L.weight.resize(K, L.c_out);
    for (int o = 0; o < L.c_out; ++o)
      for (int c = 0; c < L.c_in; ++c)
        for (int ky = 0; ky < L.k_h; ++ky)
          for (int kx = 0; kx < L.k_w; ++kx)
            L.weight((kx * L.k_h + ky) * L.c_in + c, o) =
                w_oihw[((static_cast<size_t>(o) * L.c_in + c) * L.k_h + ky) * L.k_w + kx];
    L.bias = Eigen::VectorXf::Zero(L.c_out);
    if (bias) {
      if (static_cast<int>(bias->size()) != L.c_out) reject(n, "bias length");
      for (int o = 0; o < L.c_out; ++o) L.bias(o) = (*bias)[o];
    }
    Op op = make_op(OpKind::Linear, n.name(), {in_id});
    op.linear = static_cast<int>(model_.linear.size());
    op.out = define(n.output(0), L.out);
    model_.linear.push_back(std::move(L));
    model_.ops.push_back(op);
  }

  void add_node(const onnx::NodeProto& n) {
    const std::string& t = n.op_type();
    const std::string ctx = where(n);
    if (t == "Constant") {
      const auto* a = attr(n, "value");
      if (!a || !a->has_t()) reject(n, "Constant without a tensor 'value'");
      if (n.output_size() < 1 || n.output(0).empty()) throw InputError(ctx + ": has no output");
      inits_[n.output(0)] = read_tensor(a->t(), ctx);
      return;
    }
    require_io(n, 1);
    (this->*ops().at(t))(n, t, ctx);
    // A vector in (N x K) gives vectors out, unless the node said otherwise.
    for (const std::string& out : n.output())
      if (ids_.count(out) && !dims_.count(out) && dims_.count(n.input(0)) && dims_.at(n.input(0)).size() == 2) {
        const Shape o = model_.values[static_cast<size_t>(ids_.at(out))];
        if (o.h == 1 && o.w == 1) dims_[out] = {1, o.c};
      }
    check_output_shapes(n);
  }

  using Adder = void (Loader::*)(const onnx::NodeProto&, const std::string&, const std::string&);
  /// The supported operators (besides Constant) and their handlers.
  static const std::map<std::string, Adder>& ops() {
    static const std::map<std::string, Adder> kOps = {{"Conv", &Loader::add_conv},
                                                      {"Gemm", &Loader::add_gemm},
                                                      {"MatMul", &Loader::add_gemm},
                                                      {"Relu", &Loader::add_relu},
                                                      {"Add", &Loader::add_arith},
                                                      {"Sub", &Loader::add_arith},
                                                      {"Mul", &Loader::add_arith},
                                                      {"Div", &Loader::add_arith},
                                                      {"MaxPool", &Loader::add_pool},
                                                      {"AveragePool", &Loader::add_pool},
                                                      {"GlobalAveragePool", &Loader::add_global_avg_pool},
                                                      {"ReduceMean", &Loader::add_reduce_mean},
                                                      {"Flatten", &Loader::add_reshape},
                                                      {"Reshape", &Loader::add_reshape},
                                                      {"Slice", &Loader::add_slice},
                                                      {"Pad", &Loader::add_pad},
                                                      {"Concat", &Loader::add_concat},
                                                      {"Identity", &Loader::add_identity},
                                                      {"Dropout", &Loader::add_identity},
                                                      {"Clip", &Loader::add_activation},
                                                      {"LeakyRelu", &Loader::add_activation},
                                                      {"Sigmoid", &Loader::add_activation},
                                                      {"Tanh", &Loader::add_activation},
                                                      {"HardSigmoid", &Loader::add_activation},
                                                      {"HardSwish", &Loader::add_activation},
                                                      {"Softmax", &Loader::add_softmax},
                                                      {"Shape", &Loader::add_shape},
                                                      {"Gather", &Loader::add_gather},
                                                      {"Unsqueeze", &Loader::add_squeeze},
                                                      {"Squeeze", &Loader::add_squeeze},
                                                      {"Cast", &Loader::add_cast},
                                                      {"Transpose", &Loader::add_transpose},
                                                      {"Split", &Loader::add_split},
                                                      {"BatchNormalization", &Loader::add_batch_norm}};
    return kOps;
  }

  void add_conv(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& ctx) {
    require_io(n, 2);
    check_known_attrs(n, {"dilations", "group", "kernel_shape", "pads", "strides", "auto_pad"});
    const auto* ap = attr(n, "auto_pad");
    if (ap && ap->s() != "NOTSET") reject(n, "auto_pad '" + ap->s() + "'");
    const int64_t group = int_attr(n, "group", 1);
    const auto dil = checked_ints(n, "dilations", {1, 1}, 2, 1, kMaxDim);
    const int in_id = map_value(n, n.input(0));
    const Init& w = init(n.input(1), ctx);
    if (w.dims.size() != 4) reject(n, "weight rank");
    for (auto d : w.dims)
      if (d < 1 || d > kMaxDim) reject(n, "weight dims");
    LinearLayer L;
    L.c_out = static_cast<int>(w.dims[0]);
    const int c_in_group = static_cast<int>(w.dims[1]);
    if (group < 1 || group > kMaxDim || L.c_out % group != 0) reject(n, "group (must divide the output channels)");
    L.group = static_cast<int>(group);
    L.c_in = c_in_group * L.group;
    const int kh = static_cast<int>(w.dims[2]), kw = static_cast<int>(w.dims[3]);
    if (attr(n, "kernel_shape") && checked_ints(n, "kernel_shape", {}, 2, 1, kMaxDim) != std::vector<int>{kh, kw})
      reject(n, "kernel_shape that differs from the weight");
    // A dilated kernel is mapped as the dense kernel it spans, zeros between its taps.
    if (static_cast<int64_t>(kh - 1) * dil[0] + 1 > kMaxDim || static_cast<int64_t>(kw - 1) * dil[1] + 1 > kMaxDim)
      reject(n, "dilated kernel extent");
    L.k_h = (kh - 1) * dil[0] + 1;
    L.k_w = (kw - 1) * dil[1] + 1;
    const Shape in = model_.values[in_id];
    if (in.c != L.c_in) reject(n, "input channels (" + std::to_string(in.c) + ") != weight channels");
    const auto st = checked_ints(n, "strides", {1, 1}, 2, 1, kMaxDim);
    const auto p = checked_ints(n, "pads", {0, 0, 0, 0}, 4, 0, kMaxDim);
    L.stride_h = st[0];
    L.stride_w = st[1];
    L.pad_t = p[0];
    L.pad_l = p[1];
    L.pad_b = p[2];
    L.pad_r = p[3];
    L.out = {L.c_out, window_out(n, in.h, L.pad_t, L.pad_b, L.k_h, L.stride_h),
             window_out(n, in.w, L.pad_l, L.pad_r, L.k_w, L.stride_w)};
    if (static_cast<int64_t>(L.rows()) * L.c_out > kMaxTensorElements / 4) reject(n, "layer size");
    const std::vector<float>& w0 = floats(n.input(1), ctx, static_cast<int64_t>(c_in_group) * kh * kw * L.c_out);
    std::vector<float> wd;  // the dilated kernel spread over its extent
    if (L.k_h != kh || L.k_w != kw) {
      if (static_cast<int64_t>(L.rows() / L.group) * L.c_out > kMaxTensorElements / 4) reject(n, "dilated layer size");
      wd.assign(static_cast<size_t>(L.c_out) * c_in_group * L.k_h * L.k_w, 0.0f);
      for (size_t oc = 0; oc < static_cast<size_t>(L.c_out) * c_in_group; ++oc)
        for (int y = 0; y < kh; ++y)
          for (int x = 0; x < kw; ++x)
            wd[(oc * L.k_h + static_cast<size_t>(y) * dil[0]) * L.k_w + static_cast<size_t>(x) * dil[1]] =
                w0[(oc * kh + y) * kw + x];
    }
    const std::vector<float>& wg = wd.empty() ? w0 : wd;
    std::vector<float> wf;  // O x C x kh x kw over every input channel: zero outside the group
    if (L.group > 1) {
      const size_t kk = static_cast<size_t>(L.k_h) * L.k_w, per_out = static_cast<size_t>(L.c_out / L.group);
      wf.assign(static_cast<size_t>(L.c_out) * L.c_in * kk, 0.0f);
      for (int o = 0; o < L.c_out; ++o) {
        const size_t gi = static_cast<size_t>(o) / per_out;
        for (int c = 0; c < c_in_group; ++c)
          std::copy_n(wg.begin() + static_cast<std::ptrdiff_t>((static_cast<size_t>(o) * c_in_group + c) * kk), kk,
                      wf.begin() + static_cast<std::ptrdiff_t>((static_cast<size_t>(o) * L.c_in + gi * c_in_group + c) * kk));
      }
    }
    const std::vector<float>* b = has_input(n, 2) ? &floats(n.input(2), ctx, L.c_out) : nullptr;
    const bool grouped = L.group > 1;
    add_linear(n, std::move(L), in_id, grouped ? wf : wg, b);
  }

  void add_gemm(const onnx::NodeProto& n, const std::string& t, const std::string& ctx) {
    if (t == "Gemm") {
      check_known_attrs(n, {"alpha", "beta", "transA", "transB"});
      if (int_attr(n, "transA", 0) != 0) reject(n, "transA = 1");
    } else {
      check_known_attrs(n, {});
    }
    require_io(n, 2);
    const int in_id = value(n.input(0), ctx);
    const Shape in = model_.values[in_id];
    if (dims_of(n.input(0)).size() != 2)
      reject(n, "input '" + n.input(0) + "' of shape " + dims_text(dims_of(n.input(0))) +
                    " (only N x K; insert Flatten)");
    const Init& w = init(n.input(1), ctx);
    if (w.dims.size() != 2 || w.dims[0] < 1 || w.dims[1] < 1 || w.dims[0] > kMaxDim * 64 || w.dims[1] > kMaxDim)
      reject(n, "weight rank or dims");
    const bool trans_b = t == "Gemm" && int_attr(n, "transB", 0) != 0;
    const int K = static_cast<int>(trans_b ? w.dims[1] : w.dims[0]);
    const int N = static_cast<int>(trans_b ? w.dims[0] : w.dims[1]);
    if (K != in.c) reject(n, "inner dimension " + std::to_string(K) + " vs input " + std::to_string(in.c));
    const float alpha = t == "Gemm" ? float_attr(n, "alpha", 1.0f) : 1.0f;
    const float beta = t == "Gemm" ? float_attr(n, "beta", 1.0f) : 1.0f;
    if (!std::isfinite(alpha) || !std::isfinite(beta)) reject(n, "non-finite alpha or beta");
    const std::vector<float>& wf = floats(n.input(1), ctx, static_cast<int64_t>(K) * N);
    std::vector<float> w_oi(static_cast<size_t>(N) * K);  // as OIHW with H = W = 1
    for (int o = 0; o < N; ++o)
      for (int k = 0; k < K; ++k)
        w_oi[static_cast<size_t>(o) * K + k] =
            alpha * (trans_b ? wf[static_cast<size_t>(o) * K + k] : wf[static_cast<size_t>(k) * N + o]);
    std::vector<float> bias;
    if (has_input(n, 2))
      for (float v : floats(n.input(2), ctx, N)) bias.push_back(beta * v);
    LinearLayer L;
    L.is_conv = false;
    L.c_in = K;
    L.c_out = N;
    L.out = {N, 1, 1};
    add_linear(n, std::move(L), in_id, w_oi, bias.empty() ? nullptr : &bias);
  }

  void add_relu(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& ctx) {
    check_known_attrs(n, {});
    const int in_id = value(n.input(0), ctx);
    Op op = make_op(OpKind::Relu, n.name(), {in_id});
    op.out = define(n.output(0), model_.values[in_id]);
    model_.ops.push_back(op);
  }

  /// Add, Sub, Mul, Div. Of two computed values: an element-wise op of two values, each
  /// broadcast along its axes of extent 1 (add_binary). With a constant operand (a scalar or one
  /// value per channel): an affine op, or, for an Add of a constant to a linear layer's output
  /// that nothing else reads (MatMul + Add, a bias), folded into that layer's bias.
  void add_arith(const onnx::NodeProto& n, const std::string& t, const std::string& ctx) {
    check_known_attrs(n, {});
    require_io(n, 2);
    const bool c0 = inits_.count(n.input(0)) > 0, c1 = inits_.count(n.input(1)) > 0;
    if (!c0 && !c1) return add_binary(n, t, ctx);
    if (c0 && c1) return fold_arith(n, t, ctx);
    const std::string& var = n.input(c0 ? 1 : 0);
    const int in_id = value(var, ctx);
    const Shape in = model_.values[in_id];
    const std::vector<float>& k = floats(n.input(c0 ? 0 : 1), ctx);
    const Init& kt = init(n.input(c0 ? 0 : 1), ctx);
    // One value, or one per channel: by ONNX's broadcasting (dims aligned at the end), a
    // constant that varies only along axis 1 of the computed value and leaves its shape as it
    // is ([C] and [1, C] of an N x C vector; [C, 1, 1] or [1, C, 1, 1] of an N x C x H x W map).
    const std::vector<int64_t> d = dims_of(var);
    bool fits = kt.dims.size() <= d.size();
    for (size_t q = 0; q < kt.dims.size() && fits; ++q) {
      const size_t ax = d.size() - kt.dims.size() + q;
      fits = kt.dims[q] == 1 || (ax == 1 && kt.dims[q] == d[ax]);
    }
    if (!fits || !(k.size() == 1 || static_cast<int>(k.size()) == in.c))
      reject(n, "constant operand of shape " + dims_text(kt.dims) + " for a value of shape " + dims_text(d) +
                    " (only a scalar or one value per channel, along axis 1)");
    auto at = [&](int c) { return k.size() == 1 ? k[0] : k[static_cast<size_t>(c)]; };
    Op op = make_op(OpKind::Affine, n.name(), {in_id});
    op.scale = Eigen::VectorXf::Ones(in.c);
    op.shift = Eigen::VectorXf::Zero(in.c);
    for (int c = 0; c < in.c; ++c) {
      const float v = at(c);
      if (t == "Add") {
        op.shift(c) = v;
      } else if (t == "Sub") {  // x - k, or k - x
        op.scale(c) = c0 ? -1.0f : 1.0f;
        op.shift(c) = c0 ? v : -v;
      } else if (t == "Mul") {
        op.scale(c) = v;
      } else {  // Div
        if (c0) reject(n, "division by a computed value");
        if (v == 0) reject(n, "division by zero");
        op.scale(c) = 1.0f / v;
      }
    }
    op.out = define(n.output(0), in);
    // A bias after a linear layer whose output nothing else reads is folded into the layer once
    // the whole graph is read (fold_biases: only then are all the readers known).
    if (t == "Add") bias_adds_.insert(op.out);
    model_.ops.push_back(op);
  }

  /// Add, Sub, Mul, Div of two computed values of the same rank (2 or 4), by ONNX's
  /// (numpy's) broadcasting: along every axis the extents are equal or one of them is 1, and
  /// the result has the larger. (Values of different ranks align at the end, which here would
  /// pair a vector's channels with a map's width: refused.)
  void add_binary(const onnx::NodeProto& n, const std::string& t, const std::string& ctx) {
    const int a = value(n.input(0), ctx), b = value(n.input(1), ctx);
    const std::vector<int64_t> da = dims_of(n.input(0)), db = dims_of(n.input(1));
    auto refuse = [&] {
      reject(n, "broadcasting of inputs of shapes " + dims_text(da) + " and " + dims_text(db) +
                    " (along each axis the extents must be equal or one of them 1, in values of the same rank)");
    };
    if (da.size() != db.size()) refuse();
    std::vector<int64_t> d(da.size());
    for (size_t q = 0; q < d.size(); ++q) {
      if (da[q] != db[q] && da[q] != 1 && db[q] != 1) refuse();
      d[q] = std::max(da[q], db[q]);
    }
    const OpKind kind = t == "Add" ? OpKind::Add : t == "Sub" ? OpKind::Sub : t == "Mul" ? OpKind::Mul : OpKind::Div;
    Op op = make_op(kind, n.name(), {a, b});
    op.out = define(n.output(0), shape_for(d, model_.values[static_cast<size_t>(a)]));
    if (d.size() == 2) dims_[n.output(0)] = d;
    model_.ops.push_back(op);
  }

  /// Add, Sub, Mul, Div of two constants (shape arithmetic): a scalar with a vector, or two of
  /// the same length; integers stay integers (Div truncates), floats if either is.
  void fold_arith(const onnx::NodeProto& n, const std::string& t, const std::string& ctx) {
    const Init &a = init(n.input(0), ctx), &b = init(n.input(1), ctx);
    const size_t na = a.f.empty() ? a.i.size() : a.f.size(), nb = b.f.empty() ? b.i.size() : b.f.size();
    if (!(na == nb || na == 1 || nb == 1) || na == 0 || nb == 0) reject(n, "broadcasting of constants other than a scalar");
    Init out;
    out.dims = na >= nb ? a.dims : b.dims;
    const size_t len = std::max(na, nb);
    const bool fl = !a.f.empty() || !b.f.empty();
    for (size_t k = 0; k < len; ++k) {
      const size_t ka = na == 1 ? 0 : k, kb = nb == 1 ? 0 : k;
      if (fl) {
        const double x = a.f.empty() ? static_cast<double>(a.i[ka]) : a.f[ka];
        const double y = b.f.empty() ? static_cast<double>(b.i[kb]) : b.f[kb];
        const double r = t == "Add" ? x + y : t == "Sub" ? x - y : t == "Mul" ? x * y : x / y;
        if (!std::isfinite(r)) reject(n, "constant arithmetic with a non-finite result");
        out.f.push_back(static_cast<float>(r));
      } else {
        const int64_t x = a.i[ka], y = b.i[kb];
        constexpr int64_t kBig = int64_t{1} << 40;  // shapes are far below this
        if (std::llabs(x) > kBig || std::llabs(y) > kBig) reject(n, "constant arithmetic on integers beyond 2^40");
        if (t == "Div" && y == 0) reject(n, "integer division by zero");
        out.i.push_back(t == "Add" ? x + y : t == "Sub" ? x - y : t == "Mul" ? x * y : x / y);
      }
    }
    inits_[n.output(0)] = std::move(out);
  }

  /// Identity and (inference) Dropout: the output is the input.
  void add_identity(const onnx::NodeProto& n, const std::string& t, const std::string& ctx) {
    if (t == "Dropout") {
      check_known_attrs(n, {"seed", "ratio"});
      if (has_input(n, 2)) reject(n, "training_mode input (export the model in eval mode)");
    } else {
      check_known_attrs(n, {});
    }
    const auto c = inits_.find(n.input(0));
    if (c != inits_.end()) {  // a constant under a second name (exporters share weights so)
      const Init copy = c->second;
      inits_[n.output(0)] = copy;
      return;
    }
    ids_[n.output(0)] = view(n.input(0), ctx);
    if (dims_.count(n.input(0))) dims_[n.output(0)] = dims_.at(n.input(0));
  }

  void add_activation(const onnx::NodeProto& n, const std::string& t, const std::string& ctx) {
    const int in_id = value(n.input(0), ctx);
    Op op = make_op(OpKind::Activation, n.name(), {in_id});
    if (t == "Clip") {  // bounds as inputs (opset 11+) or attributes (opset 6)
      check_known_attrs(n, {"min", "max"});
      op.activation = Activation::Clip;
      op.lo = float_attr(n, "min", -std::numeric_limits<float>::infinity());
      op.hi = float_attr(n, "max", std::numeric_limits<float>::infinity());
      if (has_input(n, 1)) op.lo = floats(n.input(1), ctx, 1)[0];
      if (has_input(n, 2)) op.hi = floats(n.input(2), ctx, 1)[0];
      if (!(op.lo <= op.hi)) reject(n, "min above max");
    } else if (t == "LeakyRelu") {
      check_known_attrs(n, {"alpha"});
      op.activation = Activation::LeakyRelu;
      op.alpha = float_attr(n, "alpha", 0.01f);
    } else if (t == "Sigmoid") {
      check_known_attrs(n, {});
      op.activation = Activation::Sigmoid;
    } else if (t == "Tanh") {
      check_known_attrs(n, {});
      op.activation = Activation::Tanh;
    } else if (t == "HardSigmoid") {
      check_known_attrs(n, {"alpha", "beta"});
      op.activation = Activation::HardSigmoid;
      op.alpha = float_attr(n, "alpha", 0.2f);
      op.beta = float_attr(n, "beta", 0.5f);
    } else {
      check_known_attrs(n, {});
      op.activation = Activation::HardSwish;
    }
    if (!std::isfinite(op.alpha) || !std::isfinite(op.beta)) reject(n, "non-finite alpha or beta");
    op.out = define(n.output(0), model_.values[in_id]);
    model_.ops.push_back(op);
  }

  void add_softmax(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& ctx) {
    check_known_attrs(n, {"axis"});
    const int in_id = value(n.input(0), ctx);
    const Shape in = model_.values[in_id];
    // Over the channels only: axis 1 of N x K or N x C x H x W (opset 13: that one axis).
    const std::vector<int64_t> d = dims_of(n.input(0));
    if (normalized_axis(n, int_attr(n, "axis", -1), d) != 1)
      reject(n, "axis " + std::to_string(int_attr(n, "axis", -1)) + " of a value of shape " + dims_text(d) +
                    " (only the channels, axis 1)");
    Op op = make_op(OpKind::Softmax, n.name(), {in_id});
    op.out = define(n.output(0), in);
    model_.ops.push_back(op);
  }

  void add_concat(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& ctx) {
    check_known_attrs(n, {"axis"});
    if (std::all_of(n.input().begin(), n.input().end(), [&](const std::string& x) { return inits_.count(x) > 0; })) {
      Init out;  // shape arithmetic: vectors joined end to end
      for (const std::string& name : n.input()) {
        const Init& c = init(name, ctx);
        if (c.dims.size() > 1 || !c.f.empty()) reject(n, "concatenation of constants other than integer vectors");
        out.i.insert(out.i.end(), c.i.begin(), c.i.end());
      }
      out.dims = {static_cast<int64_t>(out.i.size())};
      inits_[n.output(0)] = std::move(out);
      return;
    }
    std::vector<int> in;
    for (const std::string& name : n.input()) in.push_back(value(name, ctx));
    const Shape first = model_.values[in.front()];
    const std::vector<int64_t> d0 = dims_of(n.input(0));
    if (normalized_axis(n, int_attr(n, "axis", 1), d0) != 1)
      reject(n, "axis " + std::to_string(int_attr(n, "axis", 1)) + " of values of shape " + dims_text(d0) +
                    " (only the channels, axis 1)");
    Shape out{0, first.h, first.w};
    for (int q = 0; q < n.input_size(); ++q) {
      const std::vector<int64_t> dq = dims_of(n.input(q));
      bool same = dq.size() == d0.size();
      for (size_t a = 0; a < dq.size() && same; ++a) same = a == 1 || dq[a] == d0[a];
      if (!same) reject(n, "inputs of shapes " + dims_text(d0) + " and " + dims_text(dq) + " (they must differ only in axis 1)");
      out.c += model_.values[in[static_cast<size_t>(q)]].c;
    }
    Op op = make_op(OpKind::Concat, n.name(), in);
    op.out = define(n.output(0), out);
    model_.ops.push_back(op);
  }

  /// ReduceMean over the spatial axes: a global average pooling.
  void add_reduce_mean(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& ctx) {
    check_known_attrs(n, {"axes", "keepdims", "noop_with_empty_axes"});
    std::vector<int64_t> axes = ints(n, "axes", {});
    if (has_input(n, 1)) axes = integers(n.input(1), ctx);  // opset 18
    const int in_id = map_value(n, n.input(0));
    for (int64_t& a : axes) a = normalized_axis(n, a, dims_of(n.input(0)));
    std::sort(axes.begin(), axes.end());
    if (axes != std::vector<int64_t>{2, 3}) reject(n, "axes (only the spatial axes 2 and 3 of N x C x H x W)");
    Op op = make_op(OpKind::GlobalAvgPool, n.name(), {in_id});
    op.out = define(n.output(0), Shape{model_.values[in_id].c, 1, 1});
    if (int_attr(n, "keepdims", 1) == 0) dims_[n.output(0)] = {1, model_.values[in_id].c};
    model_.ops.push_back(op);
  }

  void add_pool(const onnx::NodeProto& n, const std::string& t, const std::string& /*ctx*/) {
    check_known_attrs(n, {"kernel_shape", "strides", "pads", "ceil_mode", "dilations", "storage_order",
                          "count_include_pad", "auto_pad"});
    const auto* ap = attr(n, "auto_pad");
    if (ap && ap->s() != "NOTSET") reject(n, "auto_pad '" + ap->s() + "'");
    const bool ceil_mode = int_attr(n, "ceil_mode", 0) != 0;
    checked_ints(n, "dilations", {1, 1}, 2, 1, 1);
    const int in_id = map_value(n, n.input(0));
    const Shape in = model_.values[in_id];
    const auto k = checked_ints(n, "kernel_shape", {}, 2, 1, kMaxDim);
    const auto st = checked_ints(n, "strides", {1, 1}, 2, 1, kMaxDim);
    const auto p = checked_ints(n, "pads", {0, 0, 0, 0}, 4, 0, kMaxDim);
    Op op = make_op(t == "MaxPool" ? OpKind::MaxPool : OpKind::AvgPool, n.name(), {in_id});
    op.k_h = k[0];
    op.k_w = k[1];
    op.s_h = st[0];
    op.s_w = st[1];
    op.p_t = p[0];
    op.p_l = p[1];
    op.p_b = p[2];
    op.p_r = p[3];
    if (op.p_t >= op.k_h || op.p_b >= op.k_h || op.p_l >= op.k_w || op.p_r >= op.k_w)
      reject(n, "pads as large as the pooling window");
    op.count_include_pad = t == "AveragePool" && int_attr(n, "count_include_pad", 0) != 0;
    Shape out{in.c, window_out(n, in.h, op.p_t, op.p_b, op.k_h, op.s_h),
              window_out(n, in.w, op.p_l, op.p_r, op.k_w, op.s_w)};
    if (ceil_mode) {
      // One more window where the stride leaves a remainder, if it starts inside the input or
      // its leading padding (ONNX and PyTorch drop a window that would start in the trailing pad).
      auto ceil_out = [](int in_d, int lo, int hi, int k, int s) {
        const int floor_out = (in_d + lo + hi - k) / s + 1;
        int o = (in_d + lo + hi - k + s - 1) / s + 1;
        if (o > floor_out && (o - 1) * s >= in_d + lo) --o;
        return o;
      };
      out.h = ceil_out(in.h, op.p_t, op.p_b, op.k_h, op.s_h);
      out.w = ceil_out(in.w, op.p_l, op.p_r, op.k_w, op.s_w);
    }
    op.out = define(n.output(0), out);
    model_.ops.push_back(op);
  }

  void add_global_avg_pool(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& /*ctx*/) {
    check_known_attrs(n, {});
    const int in_id = map_value(n, n.input(0));
    Op op = make_op(OpKind::GlobalAvgPool, n.name(), {in_id});
    op.out = define(n.output(0), Shape{model_.values[in_id].c, 1, 1});
    model_.ops.push_back(op);
  }

  /// Gives computed value `in_name` the dims `d` (batch first, N = 1) under the name `out`:
  /// the data keep their C, H, W order. Rank 2 is a vector, rank 4 a C x H x W map; other
  /// ranks are views that only Reshape, Transpose, Squeeze, Unsqueeze and Shape read.
  void relabel(const onnx::NodeProto& n, const std::string& in_name, std::vector<int64_t> d, const std::string& out) {
    const int in_id = view(in_name, where(n));
    const Shape in = model_.values[static_cast<size_t>(in_id)];
    if (d.empty() || d[0] != 1) reject(n, "result whose first (batch) dimension is not 1");
    int64_t count = 1;
    for (int64_t x : d) {
      if (x < 1 || x > kMaxDim * 64 || count > kMaxTensorElements / x) reject(n, "target shape");
      count *= x;
    }
    if (count != in.size())
      reject(n, "reshape to " + std::to_string(count) + " elements of a value of " + std::to_string(in.size()));
    Shape s = in;
    if (d.size() == 2) s = Shape{static_cast<int>(d[1]), 1, 1};
    if (d.size() == 4) s = Shape{static_cast<int>(d[1]), static_cast<int>(d[2]), static_cast<int>(d[3])};
    const size_t in_rank = dims_of(in_name).size();
    dims_[out] = d;
    // To or from a view, the same data under another name: no operation. (Between ranks 2
    // and 4 a Flatten op remains, as it always did: a pipeline stage of its own.)
    const bool view_involved = (in_rank != 2 && in_rank != 4) || (d.size() != 2 && d.size() != 4);
    if (s == in && view_involved) {
      ids_[out] = in_id;
      return;
    }
    Op op = make_op(OpKind::Flatten, n.name(), {in_id});
    op.out = define(out, s);
    model_.ops.push_back(op);
  }

  void add_reshape(const onnx::NodeProto& n, const std::string& t, const std::string& ctx) {
    view(n.input(0), ctx);
    const std::vector<int64_t> in = dims_of(n.input(0));
    std::vector<int64_t> d;
    if (t == "Flatten") {
      check_known_attrs(n, {"axis"});
      int64_t axis = int_attr(n, "axis", 1);
      if (axis < 0) axis += static_cast<int64_t>(in.size());
      if (axis != 1) reject(n, "axis (only 1: N x everything else)");
      int64_t k = 1;
      for (size_t q = 1; q < in.size(); ++q) k *= in[q];
      d = {1, k};
    } else {
      check_known_attrs(n, {"allowzero"});
      require_io(n, 2);
      d = integers(n.input(1), ctx);
      const bool allowzero = int_attr(n, "allowzero", 0) != 0;
      if (d.size() < 2 || d.size() > 8) reject(n, "target rank " + std::to_string(d.size()) + " (2 to 8)");
      int64_t known = 1, infer = -1, count = 1;
      for (int64_t x : in) count *= x;
      for (size_t q = 0; q < d.size(); ++q) {
        if (d[q] == 0 && !allowzero) {
          if (q >= in.size()) reject(n, "target shape (a 0 past the input's rank)");
          d[q] = in[q];
        }
        if (d[q] == -1 && infer < 0)
          infer = static_cast<int64_t>(q);
        else if (d[q] < 1 || d[q] > kMaxDim * 64 || (known *= d[q]) > count)
          reject(n, "target shape");
      }
      if (infer >= 0) {
        if (count % known != 0) reject(n, "target shape that does not divide the input");
        d[static_cast<size_t>(infer)] = count / known;
      }
    }
    relabel(n, n.input(0), d, n.output(0));
  }

  // ---- Shape arithmetic, folded at load time: the operands are constants. ----

  /// Stores the integer constant `v` of dims `d` under `name`.
  void define_ints(const std::string& name, std::vector<int64_t> d, std::vector<int64_t> v) {
    Init t;
    t.dims = std::move(d);
    t.i = std::move(v);
    inits_[name] = std::move(t);
  }

  /// Shape: the dims of a computed value (optionally [start, end) of them, opset 15).
  void add_shape(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& ctx) {
    check_known_attrs(n, {"start", "end"});
    view(n.input(0), ctx);
    const std::vector<int64_t> d = dims_of(n.input(0));
    const int64_t r = static_cast<int64_t>(d.size());
    auto clampi = [&](int64_t v) { return std::clamp<int64_t>(v < 0 ? v + r : v, 0, r); };
    const int64_t b = clampi(int_attr(n, "start", 0)), e = clampi(int_attr(n, "end", r));
    std::vector<int64_t> v(d.begin() + b, d.begin() + std::max(b, e));
    define_ints(n.output(0), {static_cast<int64_t>(v.size())}, v);
  }

  /// Gather of a constant (a shape) along axis 0.
  void add_gather(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& ctx) {
    check_known_attrs(n, {"axis"});
    require_io(n, 2);
    if (!inits_.count(n.input(0))) reject(n, "gather from a computed value (only from constants such as shapes)");
    const Init& data = init(n.input(0), ctx);
    const Init& idx = init(n.input(1), ctx);
    if (int_attr(n, "axis", 0) != 0 || data.dims.size() != 1) reject(n, "gather other than along axis 0 of a vector");
    if (!idx.f.empty()) reject(n, "float indices");
    const int64_t len = data.dims[0];
    Init out;
    out.dims = idx.dims;
    for (int64_t k : idx.i) {
      if (k < -len || k >= len) reject(n, "index " + std::to_string(k) + " outside a vector of " + std::to_string(len));
      const size_t q = static_cast<size_t>(k < 0 ? k + len : k);
      if (data.f.empty())
        out.i.push_back(data.i[q]);
      else
        out.f.push_back(data.f[q]);
    }
    inits_[n.output(0)] = std::move(out);
  }

  /// Squeeze and Unsqueeze: of a constant, its dims change; of a computed value, a relabelling.
  void add_squeeze(const onnx::NodeProto& n, const std::string& t, const std::string& ctx) {
    check_known_attrs(n, {"axes"});
    std::vector<int64_t> axes = ints(n, "axes", {});
    if (has_input(n, 1)) axes = integers(n.input(1), ctx);  // opset 13
    const bool constant = inits_.count(n.input(0)) > 0;
    if (!constant) view(n.input(0), ctx);
    std::vector<int64_t> d = constant ? init(n.input(0), ctx).dims : dims_of(n.input(0));
    const int64_t r = static_cast<int64_t>(d.size()) + (t == "Unsqueeze" ? static_cast<int64_t>(axes.size()) : 0);
    for (int64_t& a : axes) {
      if (a < -r || a >= r) reject(n, "axis " + std::to_string(a) + " for rank " + std::to_string(r));
      if (a < 0) a += r;
    }
    std::sort(axes.begin(), axes.end());
    if (std::adjacent_find(axes.begin(), axes.end()) != axes.end()) reject(n, "repeated axes");
    if (t == "Unsqueeze") {
      if (axes.empty()) reject(n, "Unsqueeze without axes");
      for (int64_t a : axes) d.insert(d.begin() + a, 1);
    } else if (axes.empty()) {
      d.erase(std::remove(d.begin(), d.end(), int64_t{1}), d.end());
    } else {
      for (auto a = axes.rbegin(); a != axes.rend(); ++a) {
        if (d[static_cast<size_t>(*a)] != 1) reject(n, "squeeze of an axis of size " + std::to_string(d[static_cast<size_t>(*a)]));
        d.erase(d.begin() + *a);
      }
    }
    if (constant) {
      Init c = init(n.input(0), ctx);
      c.dims = d;
      inits_[n.output(0)] = std::move(c);
      return;
    }
    relabel(n, n.input(0), d, n.output(0));
  }

  /// Cast: of a constant, converted; of a computed value, only to float (the identity).
  void add_cast(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& ctx) {
    check_known_attrs(n, {"to", "saturate"});
    const int64_t to = int_attr(n, "to", 0);
    const bool to_float = to == onnx::TensorProto::FLOAT;
    const bool to_int = to == onnx::TensorProto::INT64 || to == onnx::TensorProto::INT32;
    if (!inits_.count(n.input(0))) {
      if (!to_float) reject(n, "cast of a computed value to a type other than float32");
      ids_[n.output(0)] = view(n.input(0), ctx);
      if (dims_.count(n.input(0))) dims_[n.output(0)] = dims_.at(n.input(0));
      return;
    }
    if (!to_float && !to_int) reject(n, "cast to type " + std::to_string(to) + " (only float32, int32, int64)");
    Init c = init(n.input(0), ctx);
    if (to_float && c.f.empty()) {
      c.f.assign(c.i.begin(), c.i.end());
      c.i.clear();
    } else if (to_int && !c.f.empty()) {
      for (float v : c.f) {
        if (!std::isfinite(v) || std::fabs(v) > 9e15f) reject(n, "cast of a non-finite or huge value to an integer");
        c.i.push_back(static_cast<int64_t>(v));  // toward zero
      }
      c.f.clear();
    }
    c.is_int32 = to == onnx::TensorProto::INT32;
    inits_[n.output(0)] = std::move(c);
  }

  /// Transpose of a value whose trailing axes are its H and W and whose leading axes (after
  /// the batch) split its channels: a channel permutation, such as a channel shuffle
  /// (N, g, C/g, H, W) -> (N, C/g, g, H, W).
  void add_transpose(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& ctx) {
    check_known_attrs(n, {"perm"});
    const int in_id = view(n.input(0), ctx);
    const Shape in = model_.values[static_cast<size_t>(in_id)];
    const std::vector<int64_t> d = dims_of(n.input(0));
    const size_t r = d.size();
    std::vector<int64_t> perm = ints(n, "perm", {});
    if (perm.empty())
      for (size_t q = r; q-- > 0;) perm.push_back(static_cast<int64_t>(q));
    std::vector<int64_t> sorted = perm;
    std::sort(sorted.begin(), sorted.end());
    for (size_t q = 0; q < r; ++q)
      if (sorted.size() != r || sorted[q] != static_cast<int64_t>(q)) reject(n, "perm that is not a permutation of the axes");
    // The channel axes: 1 .. t-1, with the axes from t on holding H x W. Take the largest t.
    size_t t = r;
    int64_t spatial = 1;
    while (t > 1 && spatial < static_cast<int64_t>(in.h) * in.w) spatial *= d[--t];
    while (t < r && d[t] == 1 && spatial == static_cast<int64_t>(in.h) * in.w && t + 1 < r) ++t;
    bool ok = perm[0] == 0 && spatial == static_cast<int64_t>(in.h) * in.w;
    for (size_t q = t; q < r && ok; ++q) ok = perm[q] == static_cast<int64_t>(q);
    if (!ok) reject(n, "transpose that moves the batch or spatial axes (only channel permutations such as a channel shuffle)");
    std::vector<int64_t> e(r);
    for (size_t q = 0; q < r; ++q) e[q] = d[static_cast<size_t>(perm[q])];
    // Output channel index (e_1 .. e_{t-1}, row-major) -> input channel index.
    std::vector<int64_t> stride_in(r, 1);
    for (size_t q = t - 1; q-- > 1;) stride_in[q] = stride_in[q + 1] * d[q + 1];
    Op op = make_op(OpKind::Shuffle, n.name(), {in_id});
    op.perm.resize(static_cast<size_t>(in.c));
    bool identity = true;
    for (int c = 0; c < in.c; ++c) {
      int64_t rest = c, src = 0;
      for (size_t q = t - 1; q >= 1; --q) {
        const int64_t idx = rest % e[q];
        rest /= e[q];
        src += idx * stride_in[static_cast<size_t>(perm[q])];
      }
      op.perm[static_cast<size_t>(c)] = static_cast<int>(src);
      identity = identity && src == c;
    }
    // The result is held as its own dims say (shape_for): N x C' x H' x W' as C' x H' x W',
    // which differs from the input's C x H x W when the transpose moves a channel axis into
    // H or W (only axes of size 1 or channel factors move: the data stay in place or are a
    // channel permutation, then relabelled).
    const Shape s = shape_for(e, in);
    if (identity) {
      if (s == in) {
        ids_[n.output(0)] = in_id;
        dims_[n.output(0)] = e;
      } else {
        relabel(n, n.input(0), e, n.output(0));
      }
      return;
    }
    if (s == in) {
      op.out = define(n.output(0), in);
      dims_[n.output(0)] = e;
      model_.ops.push_back(op);
      return;
    }
    op.out = define_unnamed(n, in);
    model_.ops.push_back(op);
    Op re = make_op(OpKind::Flatten, n.name(), {op.out});
    re.out = define(n.output(0), s);
    dims_[n.output(0)] = e;
    model_.ops.push_back(re);
  }

  /// Split of a computed value along the channels, height or width: one Slice per output.
  void add_split(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& ctx) {
    check_known_attrs(n, {"axis", "split", "num_outputs"});
    const int in_id = value(n.input(0), ctx);
    const Shape in = model_.values[static_cast<size_t>(in_id)];
    const std::vector<int64_t> d = dims_of(n.input(0));
    int64_t axis = int_attr(n, "axis", 0);
    if (axis < 0) axis += static_cast<int64_t>(d.size());
    if (axis < 1 || axis >= static_cast<int64_t>(d.size())) reject(n, "axis (not the batch)");
    const int64_t len = d[static_cast<size_t>(axis)];
    std::vector<int64_t> split = ints(n, "split", {});
    if (has_input(n, 1)) split = integers(n.input(1), ctx);  // opset 13
    const int64_t parts = n.output_size();
    if (split.empty()) {  // equal parts, the last one smaller when they do not divide
      const int64_t each = (len + parts - 1) / parts;
      for (int64_t q = 0, at = 0; q < parts; ++q, at += each) split.push_back(std::max<int64_t>(0, std::min(each, len - at)));
    }
    if (static_cast<int64_t>(split.size()) != parts) reject(n, "split with a length per output");
    int64_t at = 0;
    for (int64_t q = 0; q < parts; ++q) {
      if (split[static_cast<size_t>(q)] < 1) reject(n, "empty split part");
      Op op = make_op(OpKind::Slice, n.name(), {in_id});
      int out_dims[3] = {in.c, in.h, in.w};
      const size_t ax = d.size() == 2 ? 0 : static_cast<size_t>(axis - 1);
      op.start[ax] = static_cast<int>(at);
      out_dims[ax] = static_cast<int>(split[static_cast<size_t>(q)]);
      at += split[static_cast<size_t>(q)];
      if (at > len) reject(n, "split lengths that add up to more than the axis (" + std::to_string(len) + ")");
      if (n.output(static_cast<int>(q)).empty()) continue;
      op.out = define(n.output(static_cast<int>(q)), Shape{out_dims[0], out_dims[1], out_dims[2]});
      model_.ops.push_back(op);
    }
    if (at != len) reject(n, "split lengths that do not add up to the axis (" + std::to_string(len) + ")");
  }

  /// Slice of an integer vector constant (a shape), along its only axis.
  void fold_slice(const onnx::NodeProto& n, const std::string& ctx) {
    const Init& c = init(n.input(0), ctx);
    if (c.dims.size() != 1 || !c.f.empty()) reject(n, "slice of a constant other than an integer vector");
    const std::vector<int64_t>&b = integers(n.input(1), ctx), &e = integers(n.input(2), ctx);
    if (has_input(n, 3)) {
      const std::vector<int64_t>& axes = integers(n.input(3), ctx);
      if (axes.size() != 1 || (axes[0] != 0 && axes[0] != -1)) reject(n, "axes of a vector slice");
    }
    const int64_t step = has_input(n, 4) ? integers(n.input(4), ctx).at(0) : 1;
    if (b.size() != 1 || e.size() != 1 || step != 1) reject(n, "vector slice other than [start, end) with step 1");
    const int64_t len = c.dims[0];
    auto clampi = [&](int64_t v) { return std::clamp<int64_t>(v < 0 ? v + len : v, 0, len); };
    const int64_t lo = clampi(b[0]), hi = std::max(lo, clampi(e[0]));
    define_ints(n.output(0), {hi - lo}, std::vector<int64_t>(c.i.begin() + lo, c.i.begin() + hi));
  }

  void add_slice(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& ctx) {
    check_known_attrs(n, {});
    require_io(n, 3);
    if (inits_.count(n.input(0))) return fold_slice(n, ctx);
    const int in_id = value(n.input(0), ctx);
    const Shape in = model_.values[in_id];
    const std::vector<int64_t>& starts = integers(n.input(1), ctx);
    const std::vector<int64_t>& ends = integers(n.input(2), ctx);
    std::vector<int64_t> axes;
    if (has_input(n, 3)) axes = integers(n.input(3), ctx);
    for (size_t q = axes.size(); q < starts.size(); ++q) axes.push_back(static_cast<int64_t>(q));
    std::vector<int64_t> steps(starts.size(), 1);
    if (has_input(n, 4)) steps = integers(n.input(4), ctx);
    if (ends.size() != starts.size() || axes.size() != starts.size() || steps.size() != starts.size())
      reject(n, "starts/ends/axes/steps of different lengths");
    Op op = make_op(OpKind::Slice, n.name(), {in_id});
    const int dims[3] = {in.c, in.h, in.w};
    int out_dims[3] = {in.c, in.h, in.w};
    for (size_t q = 0; q < starts.size(); ++q) {
      const int64_t rank = static_cast<int64_t>(dims_of(n.input(0)).size());
      int64_t ax = axes[q] < 0 ? axes[q] + rank : axes[q];
      if (ax == 0) {
        if (starts[q] != 0 || steps[q] != 1) reject(n, "slicing of the batch axis");
        continue;
      }
      if (ax < 1 || ax >= rank) reject(n, "axis " + std::to_string(axes[q]) + " of a value of rank " + std::to_string(rank));
      if (steps[q] < 1 || steps[q] > kMaxDim) reject(n, "step outside [1, " + std::to_string(kMaxDim) + "]");
      const int d = dims[ax - 1];
      auto clampi = [&](int64_t v) {
        if (v < 0) v = v < -d ? 0 : v + d;
        return std::max<int64_t>(0, std::min<int64_t>(d, v));
      };
      const int64_t b = clampi(starts[q]), e = clampi(ends[q]);
      op.start[ax - 1] = static_cast<int>(b);
      op.step[ax - 1] = static_cast<int>(steps[q]);
      out_dims[ax - 1] = e > b ? static_cast<int>((e - b + steps[q] - 1) / steps[q]) : 0;
    }
    if (out_dims[0] < 1 || out_dims[1] < 1 || out_dims[2] < 1) reject(n, "empty slice");
    op.out = define(n.output(0), Shape{out_dims[0], out_dims[1], out_dims[2]});
    model_.ops.push_back(op);
  }

  void add_pad(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& ctx) {
    check_known_attrs(n, {"mode"});
    const auto* mode = attr(n, "mode");
    if (mode && mode->s() != "constant") reject(n, "mode '" + mode->s() + "'");
    const int in_id = value(n.input(0), ctx);
    const Shape in = model_.values[in_id];
    require_io(n, 2);
    const std::vector<int64_t>& p = integers(n.input(1), ctx);
    const size_t r = dims_of(n.input(0)).size();  // 2 or 4
    if (p.size() != 2 * r) reject(n, "pads of length " + std::to_string(p.size()) + " for a value of rank " + std::to_string(r));
    if (p[0] != 0 || p[r] != 0) reject(n, "padding of the batch axis");
    Op op = make_op(OpKind::Pad, n.name(), {in_id});
    for (size_t q = 0; q + 1 < r; ++q) {
      if (p[1 + q] < 0 || p[r + 1 + q] < 0 || p[1 + q] > kMaxDim || p[r + 1 + q] > kMaxDim)
        reject(n, "pads outside [0, " + std::to_string(kMaxDim) + "]");
      op.pad_lo[q] = static_cast<int>(p[1 + q]);
      op.pad_hi[q] = static_cast<int>(p[r + 1 + q]);
    }
    if (has_input(n, 2)) op.pad_value = floats(n.input(2), ctx, 1)[0];
    op.out = define(n.output(0), Shape{in.c + op.pad_lo[0] + op.pad_hi[0], in.h + op.pad_lo[1] + op.pad_hi[1],
                                       in.w + op.pad_lo[2] + op.pad_hi[2]});
    model_.ops.push_back(op);
  }

  void add_batch_norm(const onnx::NodeProto& n, const std::string& /*op_type*/, const std::string& ctx) {
    check_known_attrs(n, {"epsilon", "momentum", "training_mode"});
    if (int_attr(n, "training_mode", 0) != 0) reject(n, "training_mode = 1");
    require_io(n, 5);
    const int in_id = value(n.input(0), ctx);
    const Shape in = model_.values[in_id];
    const std::vector<float>&sc = floats(n.input(1), ctx, in.c), &b = floats(n.input(2), ctx, in.c),
          &mu = floats(n.input(3), ctx, in.c), &var = floats(n.input(4), ctx, in.c);
    const float eps = float_attr(n, "epsilon", 1e-5f);
    if (!(eps >= 0) || !std::isfinite(eps)) reject(n, "epsilon");
    Op op = make_op(OpKind::Affine, n.name(), {in_id});
    op.scale.resize(in.c);
    op.shift.resize(in.c);
    for (int c = 0; c < in.c; ++c) {
      if (!(var[c] + eps > 0)) reject(n, "variance + epsilon <= 0 in channel " + std::to_string(c));
      op.scale(c) = sc[c] / std::sqrt(var[c] + eps);
      op.shift(c) = b[c] - mu[c] * op.scale(c);
      if (!std::isfinite(op.scale(c)) || !std::isfinite(op.shift(c))) reject(n, "parameters (non-finite result)");
    }
    op.out = define(n.output(0), in);
    model_.ops.push_back(op);
  }

  const onnx::ModelProto& m_;
  std::string path_;
  Model& model_;
  std::map<std::string, Init> inits_;
  std::map<std::string, int> ids_;
  std::set<int> bias_adds_;  ///< the Affine ops' outputs that add a constant (fold_biases)
  /// ONNX dims (batch first) of computed values that are not N x C x H x W: vectors (N x K)
  /// and views of other ranks; the rest are [1, C, H, W] of their Shape.
  std::map<std::string, std::vector<int64_t>> dims_;
};

}  // namespace

std::vector<double> parse_number_list(const std::string& s, const std::string& key, const std::string& path) {
  std::vector<double> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    double v = 0;
    if (!parse_finite_ratio(item, v))
      throw InputError(path + ": '" + key + "' has an entry '" + item + "' that is not a finite number or a/b");
    out.push_back(v);
  }
  if (out.empty()) throw InputError(path + ": '" + key + "' holds no numbers");
  return out;
}

namespace {

/// Preprocessing and reference accuracy from metadata_props, with checked conversions.
void read_metadata(const onnx::ModelProto& proto, const std::string& path, Model& model) {
  for (const auto& p : proto.metadata_props()) model.metadata[p.key()] = p.value();
  for (const char* k : {"input_scale", "input_mean", "input_std"}) model.preprocessing_in_metadata |= model.metadata.count(k) > 0;
  auto meta = [&](const char* k) { return model.metadata.count(k) ? model.metadata[k] : std::string(); };
  if (!meta("input_scale").empty()) model.pre.scale = parse_number_list(meta("input_scale"), "input_scale", path).at(0);
  if (!meta("input_mean").empty()) model.pre.mean = parse_number_list(meta("input_mean"), "input_mean", path);
  if (!meta("input_std").empty()) model.pre.std = parse_number_list(meta("input_std"), "input_std", path);
  if (!(model.pre.scale > 0)) throw InputError(path + ": metadata 'input_scale' must be > 0");
  for (double v : model.pre.std)
    if (!(v > 0)) throw InputError(path + ": metadata 'input_std' values must be > 0");
  for (const auto* v : {&model.pre.mean, &model.pre.std})
    if (v->size() != 1 && static_cast<int>(v->size()) != model.input.c)
      throw InputError(path + ": metadata 'input_mean'/'input_std' need 1 or " + std::to_string(model.input.c) +
                       " values");
  model.dataset = meta("dataset");
  const std::string acc = meta("software_accuracy_test_batch");
  if (!acc.empty() && (!parse_finite_double(acc, model.reference_accuracy) || model.reference_accuracy < 0))
    throw InputError(path + ": metadata 'software_accuracy_test_batch' = '" + acc + "' is not an accuracy");
}

/// Exporters may leave node names empty; a layer, a report row and every message then name
/// nothing. An unnamed node is called by its first output (unique: every value is defined once).
void name_unnamed_nodes(onnx::ModelProto& proto) {
  for (onnx::NodeProto& n : *proto.mutable_graph()->mutable_node())
    if (n.name().empty() && n.output_size() > 0 && !n.output(0).empty()) n.set_name(n.output(0));
}

Model load_proto(onnx::ModelProto& proto, const std::string& path, Shape input) {
  name_unnamed_nodes(proto);
  Model model;
  model.path = path;
  try {
    Loader(proto, path, model).run(input);
  } catch (const std::out_of_range& e) {  // a field indexed past its end: malformed graph
    throw InputError(path + ": malformed graph (" + e.what() + ")");
  }
  read_metadata(proto, path, model);
  return model;
}

}  // namespace

Model load_onnx_model(const std::string& path, Shape input) {
  // protobuf refuses messages of 2 GiB and more.
  const std::string bytes = read_input_file(path, "the model", (size_t{2} << 30) - 1);
  onnx::ModelProto proto;
  if (!proto.ParseFromString(bytes)) throw InputError("'" + path + "' is not a valid ONNX model");
  return load_proto(proto, path, input);
}

Model load_onnx_model_from_bytes(const std::string& bytes, const std::string& origin, Shape input) {
  onnx::ModelProto proto;
  if (!proto.ParseFromString(bytes)) throw InputError("'" + origin + "' is not a valid ONNX model");
  return load_proto(proto, origin, input);
}

}  // namespace xbarsim
