"""A grpcurl-like command line that works from gRPC server reflection alone.

    python3 -m lane_client.reflection [options] TARGET list [SERVICE]
    python3 -m lane_client.reflection [options] TARGET describe SYMBOL
    python3 -m lane_client.reflection [options] [-d JSON] TARGET SERVICE/METHOD

Debian 12 has neither grpcurl nor grpc_cli, and Debian's python3-grpcio has
no reflection client; this one needs nothing but python3-grpcio and
python3-protobuf, and no generated stubs: it asks the server
(grpc.reflection.v1alpha, which lane-server serves) for the descriptors,
builds the message classes from them, converts -d's JSON (proto3 JSON
mapping, as grpcurl) into the request and prints each response as JSON.

  list               the services; with SERVICE, its methods
  describe SYMBOL    a service, method, message or enum, in proto syntax
  SERVICE/METHOD     call it (also SERVICE.METHOD). -d: the request as JSON
                     (default {}); for a client-streaming method a JSON array
                     of requests; '-d @' reads it from standard input.

Plaintext unless --ca is given (grpcurl's -plaintext is the default here).
The Bearer token comes from --token-file or $LANE_TOKEN, as lane-client.
"""

import argparse
import json
import os
import sys

import grpc
from google.protobuf import descriptor_pb2, descriptor_pool, json_format, message_factory

_REFLECTION_METHOD = "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo"

# ---------------------------------------------------------------------------
# The reflection protocol's messages, declared here by their field numbers
# (grpc.reflection.v1alpha; only the fields this tool uses), so that no
# generated module is needed.
# ---------------------------------------------------------------------------

_F = descriptor_pb2.FieldDescriptorProto


def _message(file_proto, name, fields):
    message = file_proto.message_type.add(name=name)
    oneofs = {}
    for field_name, number, kind, label, type_name, oneof in fields:
        field = message.field.add(name=field_name, number=number, type=kind, label=label)
        if type_name:
            field.type_name = type_name
        if oneof is not None:
            if oneof not in oneofs:
                oneofs[oneof] = len(message.oneof_decl)
                message.oneof_decl.add(name=oneof)
            field.oneof_index = oneofs[oneof]


def _reflection_classes():
    fp = descriptor_pb2.FileDescriptorProto(name="lane_client/reflection_client.proto",
                                            package="lane_client.reflection", syntax="proto3")
    opt, rep = _F.LABEL_OPTIONAL, _F.LABEL_REPEATED
    pkg = ".lane_client.reflection."
    _message(fp, "Request", [
        ("host", 1, _F.TYPE_STRING, opt, None, None),
        ("file_by_filename", 3, _F.TYPE_STRING, opt, None, "message_request"),
        ("file_containing_symbol", 4, _F.TYPE_STRING, opt, None, "message_request"),
        ("list_services", 7, _F.TYPE_STRING, opt, None, "message_request"),
    ])
    _message(fp, "FileDescriptors", [("file_descriptor_proto", 1, _F.TYPE_BYTES, rep, None, None)])
    _message(fp, "ServiceName", [("name", 1, _F.TYPE_STRING, opt, None, None)])
    _message(fp, "Services", [("service", 1, _F.TYPE_MESSAGE, rep, pkg + "ServiceName", None)])
    _message(fp, "Error", [("error_code", 1, _F.TYPE_INT32, opt, None, None),
                           ("error_message", 2, _F.TYPE_STRING, opt, None, None)])
    _message(fp, "Response", [
        ("valid_host", 1, _F.TYPE_STRING, opt, None, None),
        ("file_descriptor_response", 4, _F.TYPE_MESSAGE, opt, pkg + "FileDescriptors", "r"),
        ("list_services_response", 6, _F.TYPE_MESSAGE, opt, pkg + "Services", "r"),
        ("error_response", 7, _F.TYPE_MESSAGE, opt, pkg + "Error", "r"),
    ])
    pool = descriptor_pool.DescriptorPool()
    pool.Add(fp)
    return (_message_class(pool, "lane_client.reflection.Request"),
            _message_class(pool, "lane_client.reflection.Response"))


def _message_class(pool, full_name):
    descriptor = pool.FindMessageTypeByName(full_name)
    if hasattr(message_factory, "GetMessageClass"):  # protobuf >= 4.21
        return message_factory.GetMessageClass(descriptor)
    return message_factory.MessageFactory(pool).GetPrototype(descriptor)


class ReflectionError(Exception):
    pass


class Reflector:
    """Descriptors of a server's services, fetched by reflection."""

    def __init__(self, channel, metadata=(), timeout=10.0):
        self._channel = channel
        self._metadata = tuple(metadata)
        self._timeout = timeout
        self._request_cls, self._response_cls = _reflection_classes()
        self._call = channel.stream_stream(
            _REFLECTION_METHOD, request_serializer=lambda m: m.SerializeToString(),
            response_deserializer=self._response_cls.FromString)
        self.pool = descriptor_pool.DescriptorPool()
        self._files = {}      # name -> FileDescriptorProto fetched
        self._added = set()   # names added to the pool

    def _ask(self, **query):
        request = self._request_cls(**query)
        try:
            responses = list(self._call(iter([request]), timeout=self._timeout,
                                        metadata=self._metadata))
        except grpc.RpcError as e:
            if e.code() == grpc.StatusCode.UNIMPLEMENTED:
                raise ReflectionError("the server does not offer reflection "
                                      "(grpc.reflection.v1alpha)") from e
            raise
        if not responses:
            raise ReflectionError(f"no reflection answer to {query}")
        response = responses[0]
        if response.WhichOneof("r") == "error_response":
            raise ReflectionError(f"{response.error_response.error_message} "
                                  f"(code {response.error_response.error_code})")
        return response

    def services(self):
        response = self._ask(list_services="*")
        return sorted(s.name for s in response.list_services_response.service)

    def _take_files(self, response):
        for blob in response.file_descriptor_response.file_descriptor_proto:
            proto = descriptor_pb2.FileDescriptorProto.FromString(blob)
            self._files.setdefault(proto.name, proto)

    def _add_file(self, name):
        if name in self._added:
            return
        if name not in self._files:
            self._take_files(self._ask(file_by_filename=name))
        proto = self._files[name]
        for dependency in proto.dependency:
            self._add_file(dependency)
        self.pool.Add(proto)
        self._added.add(name)

    def load_symbol(self, symbol):
        """Fetches the file that defines `symbol` (and its imports) into the pool."""
        symbol = symbol.lstrip(".")
        response = self._ask(file_containing_symbol=symbol)
        first = response.file_descriptor_response.file_descriptor_proto
        self._take_files(response)
        if first:
            self._add_file(descriptor_pb2.FileDescriptorProto.FromString(first[0]).name)

    def find(self, symbol):
        """The descriptor of a service, method, message or enum (full name)."""
        symbol = symbol.lstrip(".").replace("/", ".")
        try:
            self.load_symbol(symbol)
        except ReflectionError as e:
            # A method: the server knows its service.
            try:
                self.load_symbol(symbol.rsplit(".", 1)[0])
            except ReflectionError:
                raise ReflectionError(f"symbol not found: {symbol} (server: {e})") from None
        for finder in (self.pool.FindServiceByName, self.pool.FindMessageTypeByName,
                       self.pool.FindEnumTypeByName, self.pool.FindMethodByName):
            try:
                return finder(symbol)
            except KeyError:
                continue
        raise ReflectionError(f"symbol not found: {symbol}")

    def message_class(self, descriptor):
        return _message_class(self.pool, descriptor.full_name)


# ---------------------------------------------------------------------------
# describe: descriptors in proto syntax
# ---------------------------------------------------------------------------

_SCALARS = {
    _F.TYPE_DOUBLE: "double", _F.TYPE_FLOAT: "float", _F.TYPE_INT64: "int64",
    _F.TYPE_UINT64: "uint64", _F.TYPE_INT32: "int32", _F.TYPE_FIXED64: "fixed64",
    _F.TYPE_FIXED32: "fixed32", _F.TYPE_BOOL: "bool", _F.TYPE_STRING: "string",
    _F.TYPE_BYTES: "bytes", _F.TYPE_UINT32: "uint32", _F.TYPE_SFIXED32: "sfixed32",
    _F.TYPE_SFIXED64: "sfixed64", _F.TYPE_SINT32: "sint32", _F.TYPE_SINT64: "sint64",
}


def _type_name(field):
    if field.message_type is not None:
        return "." + field.message_type.full_name
    if field.enum_type is not None:
        return "." + field.enum_type.full_name
    return _SCALARS.get(field.type, str(field.type))


def _is_synthetic(oneof):
    """The oneof protoc makes for a proto3 `optional` field."""
    return len(oneof.fields) == 1 and oneof.name == "_" + oneof.fields[0].name


def _field_line(field, label=""):
    return f"{label}{_type_name(field)} {field.name} = {field.number};"


def _describe_method(method):
    into = "stream " if method.client_streaming else ""
    out = "stream " if method.server_streaming else ""
    return (f"rpc {method.name} ( {into}.{method.input_type.full_name} ) "
            f"returns ( {out}.{method.output_type.full_name} );")


def describe(descriptor):
    kind = type(descriptor).__name__
    lines = []
    if kind == "ServiceDescriptor":
        lines.append(f"{descriptor.full_name} is a service:")
        lines.append(f"service {descriptor.name} {{")
        lines += [f"  {_describe_method(m)}" for m in descriptor.methods]
        lines.append("}")
    elif kind == "MethodDescriptor":
        lines.append(f"{descriptor.full_name} is a method:")
        lines.append(_describe_method(descriptor))
    elif kind == "EnumDescriptor":
        lines.append(f"{descriptor.full_name} is an enum:")
        lines.append(f"enum {descriptor.name} {{")
        lines += [f"  {v.name} = {v.number};" for v in descriptor.values]
        lines.append("}")
    else:
        lines.append(f"{descriptor.full_name} is a message:")
        lines.append(f"message {descriptor.name} {{")
        done = set()
        for field in descriptor.fields:
            if field.name in done:
                continue
            oneof = field.containing_oneof
            if oneof is not None and not _is_synthetic(oneof):
                lines.append(f"  oneof {oneof.name} {{")
                for member in oneof.fields:
                    lines.append(f"    {_field_line(member)}")
                    done.add(member.name)
                lines.append("  }")
                continue
            if field.label == _F.LABEL_REPEATED:
                label = "repeated "
            elif oneof is not None:
                label = "optional "
            else:
                label = ""
            lines.append(f"  {_field_line(field, label)}")
            done.add(field.name)
        lines.append("}")
    return "\n".join(lines)


# ---------------------------------------------------------------------------
# The command line
# ---------------------------------------------------------------------------

def _channel(args):
    if args.ca:
        with open(args.ca, "rb") as f:
            root = f.read()
        key = cert = None
        if args.cert or args.key:
            if not (args.cert and args.key):
                raise SystemExit("lane_client.reflection: --cert and --key go together")
            with open(args.cert, "rb") as f:
                cert = f.read()
            with open(args.key, "rb") as f:
                key = f.read()
        options = [("grpc.ssl_target_name_override", args.servername)] if args.servername else []
        credentials = grpc.ssl_channel_credentials(root_certificates=root, private_key=key,
                                                   certificate_chain=cert)
        return grpc.secure_channel(args.target, credentials, options=options)
    return grpc.insecure_channel(args.target)


def _metadata(args):
    metadata = []
    token = None
    if args.token_file:
        with open(args.token_file) as f:
            token = (f.readline() or "").strip()
    elif os.environ.get("LANE_TOKEN"):
        token = os.environ["LANE_TOKEN"].strip()
    if token:
        metadata.append(("authorization", f"Bearer {token}"))
    for header in args.header or []:
        name, sep, value = header.partition(":")
        if not sep:
            raise SystemExit(f"lane_client.reflection: -H wants 'name: value', not {header!r}")
        metadata.append((name.strip().lower(), value.strip()))
    return metadata


def _invoke(reflector, channel, metadata, method_name, data, args):
    method = reflector.find(method_name)
    if type(method).__name__ != "MethodDescriptor":
        raise ReflectionError(f"{method_name} is not a method (SERVICE/METHOD)")
    request_cls = reflector.message_class(method.input_type)
    response_cls = reflector.message_class(method.output_type)
    text = sys.stdin.read() if data == "@" else data
    parsed = json.loads(text) if text.strip() else {}
    items = parsed if isinstance(parsed, list) else [parsed]
    if len(items) != 1 and not method.client_streaming:
        raise ReflectionError(f"{method.name} takes one request, not {len(items)}")
    requests = [json_format.ParseDict(item, request_cls()) for item in items]
    path = f"/{method.containing_service.full_name}/{method.name}"
    serialize, deserialize = (lambda m: m.SerializeToString()), response_cls.FromString
    kwargs = {"timeout": args.max_time, "metadata": metadata}
    if method.client_streaming and method.server_streaming:
        responses = channel.stream_stream(path, serialize, deserialize)(iter(requests), **kwargs)
    elif method.client_streaming:
        responses = [channel.stream_unary(path, serialize, deserialize)(iter(requests), **kwargs)]
    elif method.server_streaming:
        responses = channel.unary_stream(path, serialize, deserialize)(requests[0], **kwargs)
    else:
        responses = [channel.unary_unary(path, serialize, deserialize)(requests[0], **kwargs)]
    for response in responses:
        print(json_format.MessageToJson(response, including_default_value_fields=args.emit_defaults,
                                        indent=2))


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="python3 -m lane_client.reflection",
        description="grpcurl-like client that needs only server reflection.",
        epilog="Examples:\n"
               "  %(prog)s 127.0.0.1:50051 list\n"
               "  %(prog)s 127.0.0.1:50051 describe lane.v1.FrameRequest\n"
               "  %(prog)s 127.0.0.1:50051 lane.v1.LaneService/GetServerInfo\n"
               "  %(prog)s -d '{\"camera_id\": \"default\"}' 127.0.0.1:50051 "
               "lane.v1.LaneService/GetSession",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("-d", "--data", default="{}",
                        help="request as JSON ('@' = standard input); default {}")
    parser.add_argument("-H", "--header", action="append", help="extra metadata 'name: value'")
    parser.add_argument("--token-file", help="Bearer token: first line of FILE "
                        "(default: $LANE_TOKEN)")
    parser.add_argument("--ca", help="PEM CA file: use TLS and verify the server against it")
    parser.add_argument("--cert", help="PEM client certificate (mutual TLS)")
    parser.add_argument("--key", help="PEM client key (mutual TLS)")
    parser.add_argument("--servername", help="name to verify the server certificate against")
    parser.add_argument("--max-time", type=float, default=10.0, help="deadline, seconds")
    parser.add_argument("--emit-defaults", action="store_true",
                        help="print fields that hold their default value too")
    parser.add_argument("target", help="host:port")
    parser.add_argument("verb", help="list | describe | SERVICE/METHOD")
    parser.add_argument("symbol", nargs="?", help="for list: a service; for describe: a symbol")
    args = parser.parse_args(argv)

    channel = _channel(args)
    metadata = _metadata(args)
    reflector = Reflector(channel, metadata, timeout=args.max_time)
    try:
        if args.verb == "list":
            if args.symbol:
                service = reflector.find(args.symbol)
                if type(service).__name__ != "ServiceDescriptor":
                    raise ReflectionError(f"{args.symbol} is not a service")
                for method in service.methods:
                    print(method.full_name)
            else:
                for name in reflector.services():
                    print(name)
        elif args.verb == "describe":
            if not args.symbol:
                parser.error("describe needs a SYMBOL")
            print(describe(reflector.find(args.symbol)))
        else:
            _invoke(reflector, channel, metadata, args.verb, args.data, args)
    except ReflectionError as e:
        print(f"lane_client.reflection: {e}", file=sys.stderr)
        return 1
    except grpc.RpcError as e:
        print(f"ERROR:\n  Code: {e.code().name}\n  Message: {e.details()}", file=sys.stderr)
        return 1
    except (ValueError, json_format.ParseError) as e:
        print(f"lane_client.reflection: bad request JSON: {e}", file=sys.stderr)
        return 1
    finally:
        channel.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
