// The one way an enum's values are named in text — JSON documents, database
// rows, registers shown to people, messages, command-line options — and read
// back (docs/style.md point 8). Beside each enum stands one table of its
// values and their names, found by argument-dependent lookup:
//
//     enum class Verdict { Pass, Fail, Aborted, Error };
//     constexpr auto nameTable(Verdict)
//     {
//         using enum Verdict;
//         return std::to_array<EnumName<Verdict>>({{Pass, "pass"}, {Fail, "fail"}, {Aborted, "aborted"},
//                                                  {Error, "error"}});
//     }
//
// and everything else is generic: enumName(e), parseEnum<E>(text), enumNames<E>
// and enumNameList<E>() (for "expected a, b or c" and the HMI's allowed values).
//
// The table is checked where it is first used: every enumerator exactly once,
// in the order of their values, names unique and non-empty. An enumerator
// added to the enum and not to the table fails to compile: the compiler
// spells a named enumerator as a template argument by its name and any other
// value as a cast, "(E)7" (GCC and Clang both), so the enumerators with
// values in [-8, 128) are counted without a count written down anywhere.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

namespace hg {

/// One row of an enum's name table.
template <class E> struct EnumName {
    E value;
    std::string_view name;
};

namespace enum_names_detail {

/// Values [kLowest, kEnd) are searched for enumerators (kLowest 0 for unsigned underlying types).
constexpr int kSignedLowest = -8;
constexpr int kEnd = 128;

/// Whether `value`, one template argument as the compiler spells it, is a
/// named enumerator: "(anonymous namespace)::Kind::A" is, "(Kind)7" and
/// "((anonymous namespace)::Kind)-1" are not.
constexpr bool named(std::string_view value)
{
    const std::size_t cast = value.rfind(')');
    return cast == std::string_view::npos || value.substr(cast + 1).find_first_not_of("-0123456789") != value.npos;
}

/// How many of V... are named enumerators: one signature spells them all,
/// "[with auto ...V = {A, (E)1, ...}]" (GCC) or "[V = <A, (E)1, ...>]" (Clang).
template <auto... V> constexpr std::size_t namedAmong()
{
    constexpr std::string_view signature = __PRETTY_FUNCTION__;
    const std::size_t open = signature.find("V = ") + 4;
    const bool braces = signature[open] == '{';
    const std::size_t close = braces ? signature.find('}', open) : signature.rfind(">]");
    std::string_view list = signature.substr(open + 1, close - open - 1);
    std::size_t count = 0;
    while (!list.empty()) {
        const std::size_t comma = list.find(", ");
        count += named(list.substr(0, comma)) ? 1 : 0;
        list = comma == list.npos ? std::string_view() : list.substr(comma + 2);
    }
    return count;
}

template <class E> constexpr int lowest()
{
    return std::is_signed_v<std::underlying_type_t<E>> ? kSignedLowest : 0;
}

template <class E, int... I> constexpr std::size_t countEnumerators(std::integer_sequence<int, I...>)
{
    return namedAmong<static_cast<E>(lowest<E>() + I)...>();
}

template <class E> constexpr std::size_t enumeratorCount()
{
    return countEnumerators<E>(std::make_integer_sequence<int, kEnd - lowest<E>()>{});
}

template <class E> constexpr long long valueOf(E e)
{
    return static_cast<long long>(static_cast<std::underlying_type_t<E>>(e));
}

template <class E> constexpr auto table = nameTable(E{});

/// Every row names a value in the searched range, in increasing order (so
/// each once), with a non-empty name no other row has.
template <class E> constexpr bool wellFormed()
{
    const auto& t = table<E>;
    for (std::size_t i = 0; i < t.size(); ++i) {
        if (valueOf(t[i].value) < lowest<E>() || valueOf(t[i].value) >= kEnd) return false;
        if (i > 0 && valueOf(t[i - 1].value) >= valueOf(t[i].value)) return false;
        if (t[i].name.empty()) return false;
        for (std::size_t k = 0; k < i; ++k)
            if (t[k].name == t[i].name) return false;
    }
    return true;
}

template <class E> constexpr bool checked()
{
    static_assert(std::is_enum_v<E>, "names are for enums");
    static_assert(wellFormed<E>(), "an enum's name table lists its values in order, each once, names unique");
    static_assert(enumeratorCount<E>() == table<E>.size(), "an enum's name table names every enumerator");
    return true;
}

template <class E> constexpr const auto& checkedTable()
{
    static_assert(checked<E>());
    return table<E>;
}

template <class E, std::size_t... I> constexpr auto namesOf(std::index_sequence<I...>)
{
    return std::array<std::string_view, sizeof...(I)>{checkedTable<E>()[I].name...};
}

} // namespace enum_names_detail

/// The name of `e`; "?" for a value that is no enumerator (a cast from a number).
template <class E> constexpr std::string_view enumName(E e)
{
    for (const auto& row : enum_names_detail::checkedTable<E>())
        if (row.value == e) return row.name;
    return "?";
}

/// The enumerator named `name`; nullopt for any other text.
template <class E> constexpr std::optional<E> parseEnum(std::string_view name)
{
    for (const auto& row : enum_names_detail::checkedTable<E>())
        if (row.name == name) return row.value;
    return std::nullopt;
}

/// Every name of E, in the enumerators' order.
template <class E>
inline constexpr auto
    enumNames = enum_names_detail::namesOf<E>(std::make_index_sequence<enum_names_detail::table<E>.size()>{});

/// Every name of E in the enumerators' order, joined by `separator` and the
/// last two by `last` when given: "pass, fail, aborted, error", or with
/// (", ", " or ") "pass, fail, aborted or error".
template <class E> std::string enumNameList(std::string_view separator = ", ", std::string_view last = {})
{
    const auto& names = enumNames<E>;
    std::string list;
    for (std::size_t i = 0; i < names.size(); ++i) {
        if (i > 0) list += i + 1 == names.size() && !last.empty() ? last : separator;
        list += names[i];
    }
    return list;
}

} // namespace hg
