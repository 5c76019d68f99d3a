#pragma once
/// @file
/// `std::visit(Overload{[](A) {...}, [](B) {...}}, v)`: one lambda per
/// alternative of a variant, as the declared request tables are walked.

namespace piezo {

template <class... F>
struct Overload : F... {
  using F::operator()...;
};
// Spelt out for compilers without aggregate deduction (clang 14).
template <class... F>
Overload(F...) -> Overload<F...>;

}  // namespace piezo
