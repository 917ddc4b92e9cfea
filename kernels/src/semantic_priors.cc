// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/kernels/semantic_priors.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <istream>
#include <stdexcept>

namespace rvwo {
namespace {

struct ClassPrior {
  const char* name;
  double prior;
};
constexpr double kStatic = 0.3;

// Semantic priors P_prior(label): the probability that a point of this class moves (paper eq. 5).
// In the update (eq. 5) a prior acts through its odds Pp / (1 - Pp): 0.5 carries no evidence,
// person 0.95 multiplies the odds of "moving" by 19.
// kStatic (0.3, odds 1:2.3) for structure and furniture: a static label is weaker evidence than a
// person label, since networks miss parts of people (borders, occlusion, motion blur) far more
// often than they paint people on walls. With 0.3, one missed label on a walker moves its alpha
// from -inf to about -6, not back to 1; a wall labelled in every frame settles at alpha = 0.99.
//
// Reasons for the values that differ from kStatic:
//   0.95: people: the paper's value; the movers a service robot meets most.
//   0.85: animals move on their own, but often rest: a little below people.
//   0.8: large animals, mostly seen standing or grazing.
//   0.7: road vehicles: as often parked as driving.
//   0.6: two-wheelers and things carried or worn: they move with a person.
//   0.5: no evidence either way (the update keeps the prediction): boats, aircraft, water
//        surfaces, sky, flags; doors, fans and toys, moved now and then while in view.
//   0.45: small objects picked up and put down; screens whose content changes under a fixed frame.
//   0.4: chairs and stools: pushed around between passes, still within one.
//   0.35: soft furnishings and plants: shift or sway a little.

// Voc21: 21 classes, in the order of the label ids the networks emit.
const ClassPrior kVoc21[] = {
    {"background", kStatic}, {"aeroplane", 0.5}, {"bicycle", 0.6},   {"bird", 0.85},
    {"boat", 0.5},           {"bottle", 0.45},   {"bus", 0.7},       {"car", 0.7},
    {"cat", 0.85},           {"chair", 0.4},     {"cow", 0.8},       {"diningtable", kStatic},
    {"dog", 0.85},           {"horse", 0.85},    {"motorbike", 0.6}, {"person", 0.95},
    {"pottedplant", 0.35},   {"sheep", 0.8},     {"sofa", kStatic},  {"train", 0.7},
    {"tvmonitor", 0.45},
};

// Coco80: 80 classes, in the order of the label ids the networks emit.
const ClassPrior kCoco80[] = {
    {"person", 0.95},
    {"bicycle", 0.6},
    {"car", 0.7},
    {"motorcycle", 0.6},
    {"airplane", 0.5},
    {"bus", 0.7},
    {"train", 0.7},
    {"truck", 0.7},
    {"boat", 0.5},
    {"traffic_light", kStatic},
    {"fire_hydrant", kStatic},
    {"stop_sign", kStatic},
    {"parking_meter", kStatic},
    {"bench", kStatic},
    {"bird", 0.85},
    {"cat", 0.85},
    {"dog", 0.85},
    {"horse", 0.85},
    {"sheep", 0.8},
    {"cow", 0.8},
    {"elephant", 0.8},
    {"bear", 0.85},
    {"zebra", 0.8},
    {"giraffe", 0.8},
    {"backpack", 0.6},
    {"umbrella", 0.6},
    {"handbag", 0.6},
    {"tie", 0.6},
    {"suitcase", 0.6},
    {"frisbee", 0.6},
    {"skis", 0.6},
    {"snowboard", 0.6},
    {"sports_ball", 0.6},
    {"kite", 0.6},
    {"baseball_bat", 0.6},
    {"baseball_glove", 0.6},
    {"skateboard", 0.6},
    {"surfboard", 0.6},
    {"tennis_racket", 0.6},
    {"bottle", 0.45},
    {"wine_glass", 0.45},
    {"cup", 0.45},
    {"fork", 0.45},
    {"knife", 0.45},
    {"spoon", 0.45},
    {"bowl", 0.45},
    {"banana", 0.45},
    {"apple", 0.45},
    {"sandwich", 0.45},
    {"orange", 0.45},
    {"broccoli", 0.45},
    {"carrot", 0.45},
    {"hot_dog", 0.45},
    {"pizza", 0.45},
    {"donut", 0.45},
    {"cake", 0.45},
    {"chair", 0.4},
    {"couch", kStatic},
    {"potted_plant", 0.35},
    {"bed", kStatic},
    {"dining_table", kStatic},
    {"toilet", kStatic},
    {"tv", 0.45},
    {"laptop", 0.45},
    {"mouse", 0.45},
    {"remote", 0.45},
    {"keyboard", 0.45},
    {"cell_phone", 0.6},
    {"microwave", kStatic},
    {"oven", kStatic},
    {"toaster", kStatic},
    {"sink", kStatic},
    {"refrigerator", kStatic},
    {"book", 0.45},
    {"clock", kStatic},
    {"vase", 0.35},
    {"scissors", 0.45},
    {"teddy_bear", 0.5},
    {"hair_drier", 0.45},
    {"toothbrush", 0.45},
};

// Ade20k150: 150 classes, in the order of the label ids the networks emit.
const ClassPrior kAde20k150[] = {
    {"wall", kStatic},
    {"building", kStatic},
    {"sky", 0.5},
    {"floor", kStatic},
    {"tree", 0.35},
    {"ceiling", kStatic},
    {"road", kStatic},
    {"bed", kStatic},
    {"windowpane", kStatic},
    {"grass", 0.35},
    {"cabinet", kStatic},
    {"sidewalk", kStatic},
    {"person", 0.95},
    {"earth", kStatic},
    {"door", 0.5},
    {"table", kStatic},
    {"mountain", kStatic},
    {"plant", 0.35},
    {"curtain", 0.45},
    {"chair", 0.4},
    {"car", 0.7},
    {"water", 0.5},
    {"painting", kStatic},
    {"sofa", kStatic},
    {"shelf", kStatic},
    {"house", kStatic},
    {"sea", 0.5},
    {"mirror", kStatic},
    {"rug", kStatic},
    {"field", kStatic},
    {"armchair", 0.4},
    {"seat", 0.4},
    {"fence", kStatic},
    {"desk", kStatic},
    {"rock", kStatic},
    {"wardrobe", kStatic},
    {"lamp", kStatic},
    {"bathtub", kStatic},
    {"railing", kStatic},
    {"cushion", 0.35},
    {"base", kStatic},
    {"box", 0.45},
    {"column", kStatic},
    {"signboard", kStatic},
    {"chest_of_drawers", kStatic},
    {"counter", kStatic},
    {"sand", kStatic},
    {"sink", kStatic},
    {"skyscraper", kStatic},
    {"fireplace", kStatic},
    {"refrigerator", kStatic},
    {"grandstand", kStatic},
    {"path", kStatic},
    {"stairs", kStatic},
    {"runway", kStatic},
    {"case", kStatic},
    {"pool_table", kStatic},
    {"pillow", 0.35},
    {"screen_door", 0.5},
    {"stairway", kStatic},
    {"river", 0.5},
    {"bridge", kStatic},
    {"bookcase", kStatic},
    {"blind", kStatic},
    {"coffee_table", kStatic},
    {"toilet", kStatic},
    {"flower", 0.35},
    {"book", 0.45},
    {"hill", kStatic},
    {"bench", kStatic},
    {"countertop", kStatic},
    {"stove", kStatic},
    {"palm", 0.35},
    {"kitchen_island", kStatic},
    {"computer", 0.45},
    {"swivel_chair", 0.4},
    {"boat", 0.5},
    {"bar", kStatic},
    {"arcade_machine", kStatic},
    {"hovel", kStatic},
    {"bus", 0.7},
    {"towel", 0.45},
    {"light", kStatic},
    {"truck", 0.7},
    {"tower", kStatic},
    {"chandelier", kStatic},
    {"awning", kStatic},
    {"streetlight", kStatic},
    {"booth", kStatic},
    {"television_receiver", 0.45},
    {"airplane", 0.5},
    {"dirt_track", kStatic},
    {"apparel", 0.6},
    {"pole", kStatic},
    {"land", kStatic},
    {"bannister", kStatic},
    {"escalator", 0.6},
    {"ottoman", 0.4},
    {"bottle", 0.45},
    {"buffet", kStatic},
    {"poster", kStatic},
    {"stage", kStatic},
    {"van", 0.7},
    {"ship", 0.5},
    {"fountain", 0.5},
    {"conveyer_belt", 0.6},
    {"canopy", kStatic},
    {"washer", kStatic},
    {"plaything", 0.5},
    {"swimming_pool", 0.5},
    {"stool", 0.4},
    {"barrel", kStatic},
    {"basket", 0.45},
    {"waterfall", 0.5},
    {"tent", kStatic},
    {"bag", 0.6},
    {"minibike", 0.6},
    {"cradle", 0.35},
    {"oven", kStatic},
    {"ball", 0.6},
    {"food", 0.45},
    {"step", kStatic},
    {"tank", kStatic},
    {"trade_name", kStatic},
    {"microwave", kStatic},
    {"pot", 0.45},
    {"animal", 0.85},
    {"bicycle", 0.6},
    {"lake", 0.5},
    {"dishwasher", kStatic},
    {"screen", 0.45},
    {"blanket", 0.35},
    {"sculpture", kStatic},
    {"hood", kStatic},
    {"sconce", kStatic},
    {"vase", 0.35},
    {"traffic_light", kStatic},
    {"tray", 0.45},
    {"ashcan", kStatic},
    {"fan", 0.5},
    {"pier", kStatic},
    {"crt_screen", 0.45},
    {"plate", 0.45},
    {"monitor", 0.45},
    {"bulletin_board", kStatic},
    {"shower", kStatic},
    {"radiator", kStatic},
    {"glass", 0.45},
    {"clock", kStatic},
    {"flag", 0.5},
};

template <std::size_t N>
SemanticPriors make(const char* name, const ClassPrior (&table)[N]) {
  std::vector<std::string> classes;
  std::vector<double> priors;
  for (const ClassPrior& c : table) {
    classes.emplace_back(c.name);
    priors.push_back(c.prior);
  }
  return SemanticPriors(name, std::move(classes), std::move(priors));
}

std::string trim(std::string s) {
  const auto not_space = [](unsigned char ch) { return !std::isspace(ch); };
  s.erase(s.begin(), std::find_if(s.begin(), s.end(), not_space));
  s.erase(std::find_if(s.rbegin(), s.rend(), not_space).base(), s.end());
  return s;
}

void checkPrior(double p, const std::string& where) {
  if (!(p >= 0.0 && p <= 1.0)) throw std::invalid_argument(where + "prior must be in [0, 1]");
}

}  // namespace

std::vector<std::string> SemanticPriors::builtinNames() { return {"voc21", "coco80", "ade20k150"}; }

SemanticPriors SemanticPriors::builtin(std::string_view name) {
  if (name == "voc21") return make("voc21", kVoc21);
  if (name == "coco80") return make("coco80", kCoco80);
  if (name == "ade20k150") return make("ade20k150", kAde20k150);
  throw std::invalid_argument("unknown label set '" + std::string(name) + "' (built in: voc21, coco80, ade20k150)");
}

SemanticPriors::SemanticPriors(std::string name, std::vector<std::string> classes, std::vector<double> priors)
    : name_(std::move(name)), classes_(std::move(classes)), priors_(std::move(priors)) {
  if (classes_.size() != priors_.size()) {
    throw std::invalid_argument("label set '" + name_ + "': " + std::to_string(classes_.size()) + " classes but " +
                                std::to_string(priors_.size()) + " priors");
  }
  for (std::size_t i = 0; i < priors_.size(); ++i) checkPrior(priors_[i], "class '" + classes_[i] + "': ");
}

const std::string& SemanticPriors::className(int label) const {
  if (label < 0 || static_cast<std::size_t>(label) >= classes_.size()) {
    throw std::out_of_range("label " + std::to_string(label) + " is not in label set '" + name_ + "' of " +
                            std::to_string(classes_.size()) + " classes");
  }
  return classes_[label];
}

int SemanticPriors::labelOf(std::string_view class_name) const {
  const auto it = std::find(classes_.begin(), classes_.end(), class_name);
  return it == classes_.end() ? -1 : static_cast<int>(it - classes_.begin());
}

void SemanticPriors::set(std::string_view class_name, double prior) {
  const int label = labelOf(class_name);
  if (label < 0) {
    throw std::invalid_argument("class '" + std::string(class_name) + "' is not in label set '" + name_ + "'");
  }
  checkPrior(prior, "class '" + std::string(class_name) + "': ");
  priors_[label] = prior;
}

void SemanticPriors::overrideFrom(std::istream& in, const std::string& source) {
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    const std::string where = source + ":" + std::to_string(n) + ": ";
    line = trim(line.substr(0, line.find('#')));
    if (line.empty()) continue;
    const auto colon = line.rfind(':');
    if (colon == std::string::npos) throw std::invalid_argument(where + "expected 'class: prior'");
    const std::string cls = trim(line.substr(0, colon));
    const std::string value = trim(line.substr(colon + 1));
    std::size_t used = 0;
    double p = 0.0;
    try {
      p = std::stod(value, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != value.size()) throw std::invalid_argument(where + "'" + value + "' is not a number");
    try {
      set(cls, p);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(where + e.what());
    }
  }
}

std::vector<int> SemanticPriors::dynamicLabels(double threshold) const {
  std::vector<int> out;
  for (std::size_t i = 0; i < priors_.size(); ++i) {
    if (priors_[i] > threshold) out.push_back(static_cast<int>(i));
  }
  return out;
}

}  // namespace rvwo
