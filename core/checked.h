// Options checked once, where they enter (the command line, a config file, a
// library call), and never again: a stage takes Checked<ItsOptions>, which
// only its room's check<ItsOptions> can make, so an unchecked value cannot
// reach it and the stage need not check what it is given.
#pragma once

#include "core/error.h"

#include <utility>

namespace apo {

template <class Options>
class Checked;

// Each room that owns an options struct defines check<ItsOptions> (an
// explicit specialization, declared in its public header): a Usage error
// naming the first option out of range, or the options as Checked.
template <class Options>
Result<Checked<Options>> check(const Options& options);

template <class Options>
class Checked {
 public:
  const Options& operator*() const { return options_; }
  const Options* operator->() const { return &options_; }

 private:
  explicit Checked(Options options) : options_(std::move(options)) {}

  friend Result<Checked> check<Options>(const Options& options);
  template <class Whole, class Part>
  friend Checked<Part> partOf(const Checked<Whole>& whole, Part Whole::*member);

  Options options_;
};

// A part of checked options that hold other options (a run's, every stage's):
// checked with the whole, whose check checks each part with the part's own.
template <class Whole, class Part>
Checked<Part> partOf(const Checked<Whole>& whole, Part Whole::*member) {
  return Checked<Part>((*whole).*member);
}

}  // namespace apo
